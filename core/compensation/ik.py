"""Inverse kinematics with a robot model: the joint values that put a tool point at a target.

    solve_ik(model, targets_xyz, targets_R=None, *, tcp="marker", frame="base", hint=None,
             tol_mm=1e-6, tol_deg=1e-7, max_iterations=200) -> IKResult

Frames. RoboCal's model places the robot in the measurement (left camera) frame:
T_tcp = base · A1 · … · An · tool · tcp (core.robot.model). `frame` says where the targets are:
* "base": the robot's base frame, DH frame 0 of `model` (the calibrated base of a calibrated
  model): a target t reaches the measurement frame as base · t;
* "measurement" (alias "camera"): the left camera frame, where the cameras locate points;
* a 4x4 array: the pose of the targets' frame in the robot's base frame (a fixture frame from
  `robocal locate-fixture`, core.fixtures.file): base · frame · t.
`tcp` is a target of the model (its point and, when `model.target_rotations` has it, its
orientation on the tool) or "tool" (the tool frame itself).

Solver. Damped least squares (Levenberg–Marquardt), all N points at once: per iteration one
batched forward kinematics, the geometric Jacobian from the joint frames
    revolute:  ∂p/∂q_i = z_(i-1) × (p − o_(i-1)),  ∂ω/∂q_i = z_(i-1);   prismatic: ∂p/∂q_i = z_(i-1)
and batched solves of (JᵀJ + λ·D)·δq = Jᵀ·r, r = [p* − p; L·log(R*·Rᵀ)] (L = `length_scale_mm`
turns radians into mm), D = diag(L² for revolute, 1 for prismatic joints); λ per point shrinks
on a successful step and grows on a failed one; steps are capped at `max_step_deg` (revolute)
and the same arc at L (prismatic). A model with joint compliance (core.robot.compliance) stands at
q + δq(q): its frames come from the model as they are, and the Jacobian with respect to the
commanded q is J(q + δq)·(I + ∂δq/∂q), so the joint values sent include the deflection.
Position-only targets leave a redundant robot free: the damped
steps from the start keep the joints near it.

Branches and limits. Each point starts from its `hint` (N, n internal units, e.g. the taught
program's joints), so it lands on the branch nearest the hint. Without a hint each point follows
the previous point: all points start from the first point's solution (itself from `start`, by
default zeros moved inside the limits), and a point whose solution lies more than `follow_deg`
from its predecessor's is solved again from that solution. A revolute solution is then taken
modulo 360° to the equivalent nearest the hint that lies inside the limits. A point not solved
this way (not converged, or solved only outside the limits) is solved again with the joints kept
inside the limits (projected steps), from its hint and then from `RESTARTS` seeded starts spread
over the joint range (such a solution may lie on another branch than the hint's). If none
succeeds the point is not ok: a point reached only outside the limits keeps that unconstrained
solution in `Q` (never clipped) and `reason` names the joint and its limits; a target the solver
cannot reach within tolerance gets the distance it stays away.

Units: mm, rad internally (targets_R are rotation matrices); IKResult.Q internal (rad / mm).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.spatial.transform import Rotation

from core import transforms as tf
from core.errors import UsageError
from core.robot.model import RobotModel

TOOL_TCP = "tool"
POLISH = 1e-3           # iterate to this fraction of the tolerance (a step costs little there)
RESTARTS = 8            # starts tried, spread over the joint range, for a point its hint does not solve


@dataclass
class IKResult:
    """Joint values per target. `Q` (N, n) internal units (rad / mm); `ok` (N,) True where the
    tool point reaches the target within tolerance inside the joint limits; `reason` (N,) ""
    where ok, else why not (out of reach by how much, or which joint leaves its limits);
    `error_mm` (N,) position error at Q; `error_deg` (N,) orientation error at Q (0 without
    orientation targets); `iterations` (N,) solver iterations spent per point."""

    Q: np.ndarray
    ok: np.ndarray
    reason: list[str]
    error_mm: np.ndarray
    error_deg: np.ndarray
    iterations: np.ndarray
    tcp: str = "marker"
    frame: str = "base"
    orientation: bool = False
    targets_world: np.ndarray = field(default_factory=lambda: np.zeros((0, 4, 4)))

    def __len__(self) -> int:
        return len(self.Q)


def tcp_in_tool(model: RobotModel, tcp: str) -> np.ndarray:
    """The pose (4x4) of the tool point `tcp` in the tool frame: a target's offset and
    orientation, or the identity for "tool". UsageError naming the choices otherwise."""
    if tcp == TOOL_TCP:
        return np.eye(4)
    if tcp not in model.targets:
        choices = ", ".join([TOOL_TCP] + list(model.targets))
        raise UsageError(f"the robot '{model.name}' has no tool point '{tcp}'", field="tcp",
                         hint=f"Choose one of: {choices}.")
    return tf.make_transform(model.target_rotations.get(tcp, np.eye(3)), model.targets[tcp])


def tcp_poses(model: RobotModel, Q, tcp: str) -> np.ndarray:
    """Poses (N, 4, 4) of the tool point `tcp` in the measurement frame at Q (N, n)."""
    return model.fk_many(Q) @ tcp_in_tool(model, tcp)


def frame_to_world(model: RobotModel, frame) -> np.ndarray:
    """The transform (4x4) from the targets' frame to the measurement frame (see the module)."""
    if isinstance(frame, str):
        if frame == "base":
            return np.array(model.base, dtype=float)
        if frame in ("measurement", "camera"):
            return np.eye(4)
        raise UsageError(f"unknown frame '{frame}'", field="frame",
                         hint="Use 'base', 'measurement' (the left camera) or a fixture pose.")
    T = np.asarray(frame, dtype=float)
    if T.shape != (4, 4) or not np.allclose(T[:3, :3] @ T[:3, :3].T, np.eye(3), atol=1e-9):
        raise UsageError("a target frame must be a 4x4 rigid transform", field="frame")
    return model.base @ T


def length_scale(model: RobotModel) -> float:
    """A characteristic length of the robot (mm): its link lengths and offsets summed (turns
    rotation errors in rad into mm in the residual)."""
    total = sum(abs(j.a) + abs(j.d) for j in model.joints) + float(np.linalg.norm(model.tool[:3, 3]))
    return max(total, 1.0)


def _rotation_error(R_target: np.ndarray, R: np.ndarray) -> np.ndarray:
    """log(R*·Rᵀ) as rotation vectors (M, 3), rad, in the measurement frame."""
    return Rotation.from_matrix(R_target @ np.swapaxes(R, 1, 2)).as_rotvec()


class IKProblem:
    """The residual and Jacobian the solver works on, for targets `world` (N, 4, 4) in the
    measurement frame and the tool point's pose `tcp_T` in the tool frame (see the module):
    r = [p* − p; L·log(R*·Rᵀ)] (mm; the rotation rows only with `orientation`), J = −∂r/∂q."""

    def __init__(self, model: RobotModel, tcp_T: np.ndarray, world: np.ndarray, orientation: bool,
                 length: float):
        self.model = model
        self.tcp_T = tcp_T
        self.world = world
        self.orientation = orientation
        self.length = length
        self.rev = model.revolute_mask()
        self.n = model.dof

    def evaluate(self, Q: np.ndarray, idx: np.ndarray, jacobian: bool = True):
        """For the targets `idx` at Q (M, n): residual r (M, 3|6), position error (M,) mm,
        rotation error (M,) rad, and J (M, 3|6, n) (None when `jacobian` is False)."""
        n = self.n
        F = self.model.frames_many(Q)
        T = F[:, n + 1] @ self.tcp_T
        p = T[:, :3, 3]
        target = self.world[idx]
        e_p = target[:, :3, 3] - p
        pos = np.linalg.norm(e_p, axis=1)
        if self.orientation:
            e_o = _rotation_error(target[:, :3, :3], T[:, :3, :3])
            rot = np.linalg.norm(e_o, axis=1)
            r = np.concatenate([e_p, self.length * e_o], axis=1)
        else:
            rot = np.zeros(len(Q))
            r = e_p
        if not jacobian:
            return r, pos, rot, None
        z = F[:, :n, :3, 2]                                   # (M, n, 3) joint axes
        o = F[:, :n, :3, 3]
        rev = self.rev[None, :, None]
        Jp = np.where(rev, np.cross(z, p[:, None, :] - o), z)
        if self.orientation:
            Jo = np.where(rev, z, 0.0) * self.length
            J = np.concatenate([Jp, Jo], axis=2)              # (M, n, 6)
        else:
            J = Jp
        J = np.swapaxes(J, 1, 2)
        if self.model.compliance is not None:     # the frames stand at q + δq(q): chain rule to the commanded q
            D = np.where(self.rev[None, :, None], self.model.compliance.derivative(Q), 0.0)
            J = J @ (np.eye(n) + D)
        return r, pos, rot, J


def _levenberg_marquardt(prob: IKProblem, Q0: np.ndarray, idx: np.ndarray, *, tol_mm: float,
                         tol_rad: float, max_iterations: int, max_step: float,
                         bounds: tuple[np.ndarray, np.ndarray] | None = None):
    """Solve the points `idx` from Q0 (M, n): returns Q, converged (M,), pos err, rot err, iterations."""
    L = prob.length
    Q = np.array(Q0, dtype=float)
    if bounds is not None:
        Q = np.clip(Q, *bounds)
    M, n = Q.shape
    D = np.where(prob.rev, L * L, 1.0)
    cap = np.where(prob.rev, max_step, max_step * L)
    lam = np.full(M, 1e-3)
    iters = np.zeros(M, dtype=int)
    r, pos, rot, J = prob.evaluate(Q, idx)
    # iterate past the tolerance: near the solution each step squares the error
    done = (pos <= POLISH * tol_mm) & (rot <= POLISH * tol_rad)
    stuck = np.zeros(M, dtype=bool)
    for _ in range(max_iterations):
        act = np.flatnonzero(~done & ~stuck)
        if len(act) == 0:
            break
        Ja, ra = J[act], r[act]
        A = np.einsum("mki,mkj->mij", Ja, Ja)
        g = np.einsum("mki,mk->mi", Ja, ra)
        A = A + lam[act, None, None] * np.diag(D)[None]
        dq = np.linalg.solve(A, g[..., None])[..., 0]
        scale = np.max(np.abs(dq) / cap, axis=1)
        dq = dq / np.maximum(scale, 1.0)[:, None]
        Qt = Q[act] + dq
        if bounds is not None:
            Qt = np.clip(Qt, *bounds)
        rt, pt, ot, Jt = prob.evaluate(Qt, idx[act])
        better = np.sum(rt * rt, axis=1) < np.sum(ra * ra, axis=1)
        acc = act[better]
        Q[acc], r[acc], pos[acc], rot[acc], J[acc] = Qt[better], rt[better], pt[better], ot[better], Jt[better]
        lam[acc] = np.maximum(lam[acc] / 10.0, 1e-12)
        rej = act[~better]
        lam[rej] *= 10.0
        iters[act] += 1
        done = (pos <= POLISH * tol_mm) & (rot <= POLISH * tol_rad)
        stuck |= lam > 1e10
        # a step too small to change anything any more (the target is out of reach)
        no_move = np.max(np.abs(dq) / cap, axis=1) < 1e-15
        stuck[act[no_move]] = True
    return Q, (pos <= tol_mm) & (rot <= tol_rad), pos, rot, iters


def _wrap_near(Q: np.ndarray, hint: np.ndarray, rev: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """Revolute joints moved by whole turns to the equivalent inside the limits nearest the hint
    (nearest the hint if none lies inside)."""
    out = Q.copy()
    base = Q + 2 * np.pi * np.round((hint - Q) / (2 * np.pi))
    best = base.copy()
    best_cost = np.where((base >= lo) & (base <= hi), np.abs(base - hint), np.inf)
    for k in (-2, -1, 1, 2):
        cand = base + 2 * np.pi * k
        cost = np.where((cand >= lo) & (cand <= hi), np.abs(cand - hint), np.inf)
        take = cost < best_cost
        best = np.where(take, cand, best)
        best_cost = np.where(take, cost, best_cost)
    best = np.where(np.isinf(best_cost), base, best)
    out[:, rev] = best[:, rev]
    return out


def _limit_reason(model: RobotModel, q: np.ndarray) -> str:
    lo, hi = model.limits()
    for j, joint in enumerate(model.joints):
        if not lo[j] - 1e-12 <= q[j] <= hi[j] + 1e-12:
            if joint.revolute:
                v, a, b, u = np.rad2deg(q[j]), np.rad2deg(lo[j]), np.rad2deg(hi[j]), "°"
            else:
                v, a, b, u = q[j], lo[j], hi[j], " mm"
            return (f"outside the joint limits: q{j + 1} would be {v:.2f}{u} "
                    f"(limits {a:g}{u} … {b:g}{u})")
    return ""


def _as_targets(targets_xyz, targets_R) -> np.ndarray:
    P = np.asarray(targets_xyz, dtype=float)
    if P.ndim != 2 or P.shape[1] != 3:
        raise UsageError(f"targets must be an (N, 3) array of positions in mm, got shape {P.shape}")
    T = np.broadcast_to(np.eye(4), (len(P), 4, 4)).copy()
    T[:, :3, 3] = P
    if targets_R is not None:
        R = np.asarray(targets_R, dtype=float)
        if R.shape != (len(P), 3, 3):
            raise UsageError(f"target orientations must be an (N, 3, 3) array, got shape {R.shape}")
        T[:, :3, :3] = R
    if not np.all(np.isfinite(T)):
        raise UsageError("targets must be finite numbers")
    return T


def solve_ik(model: RobotModel, targets_xyz, targets_R=None, *, tcp: str = "marker", frame="base",
             hint=None, start=None, tol_mm: float = 1e-6, tol_deg: float = 1e-7,
             max_iterations: int = 200, max_step_deg: float = 20.0, follow_deg: float = 30.0,
             length_scale_mm: float | None = None) -> IKResult:
    """Joint values (internal units) that put the tool point `tcp` at each target.

    targets_xyz (N, 3) mm and, for position + orientation, targets_R (N, 3, 3) — the tool
    point's orientation — both in `frame` ("base", "measurement"/"camera", or a 4x4 pose of
    the targets' frame in the base frame). `hint` (N, n) internal units picks each point's
    branch; None follows the previous point from `start` (n,). See the module for the method."""
    model_n = model.dof
    world_in = _as_targets(targets_xyz, targets_R)
    N = len(world_in)
    frame_name = frame if isinstance(frame, str) else "fixture"
    world = frame_to_world(model, frame) @ world_in
    orientation = targets_R is not None
    prob = IKProblem(model, tcp_in_tool(model, tcp), world, orientation,
                    float(length_scale_mm) if length_scale_mm else length_scale(model))
    lo, hi = model.limits()
    rev = model.revolute_mask()
    kw = dict(tol_mm=tol_mm, tol_rad=np.deg2rad(tol_deg), max_iterations=max_iterations,
              max_step=np.deg2rad(max_step_deg))
    if N == 0:
        return IKResult(np.zeros((0, model_n)), np.zeros(0, bool), [], np.zeros(0), np.zeros(0),
                        np.zeros(0, int), tcp, frame_name, orientation, world)
    idx_all = np.arange(N)
    if hint is not None:
        H = np.asarray(hint, dtype=float)
        if H.shape != (N, model_n) or not np.all(np.isfinite(H)):
            raise UsageError(f"hint must be an ({N}, {model_n}) array of joint values (rad / mm)", field="hint")
        Q, conv, pos, rot, iters = _levenberg_marquardt(prob, H, idx_all, **kw)
    else:
        s = np.zeros(model_n) if start is None else np.asarray(start, dtype=float)
        if s.shape != (model_n,) or not np.all(np.isfinite(s)):
            raise UsageError(f"start must hold {model_n} joint values (rad / mm)", field="start")
        s = np.clip(s, lo, hi)
        q0, c0, p0, o0, i0 = _levenberg_marquardt(prob, s[None], idx_all[:1], **kw)
        q0 = _wrap_near(q0, s[None], rev, lo, hi)
        Q, conv, pos, rot, iters = _levenberg_marquardt(prob, np.repeat(q0, N, axis=0), idx_all, **kw)
        iters[0] += i0[0]
        H = np.empty_like(Q)
        H[0] = s
        Q[0] = q0[0]
        tol_follow = np.deg2rad(follow_deg)
        for i in range(1, N):
            Q[i] = _wrap_near(Q[i:i + 1], Q[i - 1:i], rev, lo, hi)[0]
            H[i] = Q[i - 1]
            gap = np.where(rev, Q[i] - Q[i - 1], (Q[i] - Q[i - 1]) / prob.length)
            if not conv[i] or np.max(np.abs(gap)) > tol_follow:
                qi, ci, pi, oi, ii = _levenberg_marquardt(prob, Q[i - 1:i], idx_all[i:i + 1], **kw)
                iters[i] += ii[0]
                qi = _wrap_near(qi, Q[i - 1:i], rev, lo, hi)
                if ci[0] or not conv[i]:
                    gap_new = np.max(np.abs(np.where(rev, qi[0] - Q[i - 1], (qi[0] - Q[i - 1]) / prob.length)))
                    if not conv[i] or (ci[0] and gap_new < np.max(np.abs(gap))):
                        Q[i], conv[i], pos[i], rot[i] = qi[0], ci[0], pi[0], oi[0]
    Q = _wrap_near(Q, H, rev, lo, hi)
    ok = conv & model.within_limits(Q)
    limited = conv & ~ok                 # reached, but only outside the limits: Q keeps that solution
    todo = np.flatnonzero(~ok)
    rng = np.random.default_rng(0)
    slo, shi = np.where(rev, np.maximum(lo, -2 * np.pi), lo), np.where(rev, np.minimum(hi, 2 * np.pi), hi)
    for attempt in range(RESTARTS + 1):
        if len(todo) == 0:
            break
        starts = (np.clip(H[todo], lo, hi) if attempt == 0
                  else slo + (shi - slo) * rng.random((len(todo), model_n)))
        Qr, cr, pr, orr, ir = _levenberg_marquardt(prob, starts, todo, bounds=(lo, hi), **kw)
        iters[todo] += ir
        Qr = _wrap_near(Qr, H[todo], rev, lo, hi)
        good = cr & model.within_limits(Qr)
        closer = good | (~limited[todo] & (pr < pos[todo]))
        k = todo[closer]
        Q[k], pos[k], rot[k] = Qr[closer], pr[closer], orr[closer]
        ok[todo[good]] = True
        limited[todo[good]] = False
        todo = todo[~good]
    reason = []
    for i in range(N):
        if ok[i]:
            reason.append("")
        elif limited[i]:
            reason.append(_limit_reason(model, Q[i]))
        elif pos[i] > tol_mm:
            reason.append(f"out of reach: the tool point stays {pos[i]:.3g} mm from the target")
        else:
            reason.append(f"out of reach: the orientation stays {np.rad2deg(rot[i]):.3g}° from the target")
    return IKResult(Q, ok, reason, pos, np.rad2deg(rot), iters, tcp, frame_name, orientation, world)
