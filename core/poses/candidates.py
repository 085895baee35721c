"""Candidate robot configurations for pose selection, with the reasons others were rejected.

Candidates are drawn uniformly (seeded) inside the joint limits shrunk by a user margin
(degrees for revolute joints, mm for prismatic ones). Revolute ranges wider than ±180° are
sampled within ±180°: the same tool poses, with less travel. Joint values are rounded to
0.001° (as a controller reports them and as poses.csv stores them), so what is selected is
exactly what is written. A candidate is kept when it passes every constraint that applies:

1. **self-collision** (when the robot model gives link radii, `RobotModel.collision_radius`,
   read from the optional robot-file section `"collision": {"radius": [mm per link]}`): the
   arm is a chain of capsules along its DH polyline (`arm_polyline`: for each link the `d`
   part along the previous z axis, then the `a` part), the tool link last (to the target).
   Two capsules collide when their axes come closer than the sum of their radii. Capsules
   joined through less chain length than the sum of their radii (neighbours, or neighbours
   through a zero-length wrist link) always touch at their joint and are not tested;
2. **floor** (optional `floor` in mm, z in the robot base frame, e.g. the virtual lab's table):
   every point of the arm polyline after the base and the target stay `floor_clearance` above it;
3. **visibility** (when a stereo rig is given): `core.poses.visibility.marker_visibility` — the marker
   plate inside both images with a margin, facing both cameras within an angle, at a depth
   where it is detectable. The robot's world frame must then be the left camera frame (a
   model whose base pose is known in it: the virtual lab's placed nominal robot, or a
   calibrated model).

Rejections are counted once per candidate, by the first failed constraint in the order
collision, floor, outside an image, not facing the cameras, depth out of range.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from core import transforms as tf
from core.errors import RoboCalError
from core.robot.model import RobotModel
from core.stereo.rig import StereoRig
from core.task import Monitor
from core.poses.visibility import DEFAULT_DEPTH, DEFAULT_MARGIN, DEFAULT_MAX_ANGLE, marker_visibility

REJECT_COLLISION = "self-collision"
REJECT_FLOOR = "below the floor"
REJECT_IMAGE = "marker outside an image"
REJECT_FACING = "marker not facing both cameras"
REJECT_DEPTH = "marker depth out of range"
REJECT_ORDER = (REJECT_COLLISION, REJECT_FLOOR, REJECT_IMAGE, REJECT_FACING, REJECT_DEPTH)

DEFAULT_MARGIN_DEG = 5.0
BATCH = 4096
MAX_DRAWS_PER_CANDIDATE = 250     # give up after drawing this many configurations per wanted one
MIN_DRAWS = 20000
FLOOR_CLEARANCE = 15.0            # mm


@dataclass
class VisibilityOptions:
    """The visibility constraints (core.poses.visibility): image margin (px), largest angle between
    the plate normal and the direction to each camera (deg), marker depth range (mm)."""

    margin: float = DEFAULT_MARGIN
    max_angle_deg: float = DEFAULT_MAX_ANGLE
    min_depth: float = DEFAULT_DEPTH[0]
    max_depth: float = DEFAULT_DEPTH[1]

    def as_kwargs(self) -> dict:
        return {"margin": self.margin, "max_angle_deg": self.max_angle_deg,
                "min_depth": self.min_depth, "max_depth": self.max_depth}


@dataclass
class CandidateSet:
    """Feasible configurations and what was rejected on the way.

    Q:        (M, n) configurations, internal units (rad / mm), rounded to 0.001° / 0.001 mm
    marker:   (M, 3) target positions in the robot's world frame (mm)
    depth:    (M,) marker depth in the left camera frame (mm) when a rig was given, else None
    drawn:    configurations drawn in all
    rejected: count per reason (REJECT_ORDER), each rejected configuration counted once
    lower, upper: the sampled joint range (internal units, limits minus margins)
    """

    Q: np.ndarray
    marker: np.ndarray
    depth: np.ndarray | None
    drawn: int
    rejected: dict[str, int]
    lower: np.ndarray
    upper: np.ndarray
    target: str = "marker"
    constraints: list[str] = field(default_factory=list)
    wanted: int = 0

    def __len__(self) -> int:
        return len(self.Q)

    @property
    def n_rejected(self) -> int:
        return int(sum(self.rejected.values()))


# -- geometry -------------------------------------------------------------------------------
def arm_polyline(robot: RobotModel, Q, target: str | None = "marker") -> tuple[np.ndarray, np.ndarray]:
    """Points along the arm for configurations Q (N, n): the base origin, then per joint i the
    end of its `d` part (o_(i-1) + d_i·z_(i-1)) and the frame origin o_i, then the tool origin
    and the target (when the robot has it). Returns (points (N, 2n + 2 [+1], 3), link (K−1,))
    where link[k] is the 0-based link of segment k (n for the tool link)."""
    Q = np.atleast_2d(np.asarray(Q, dtype=float))
    F = robot.frames_many(Q)
    n = robot.dof
    rev = robot.revolute_mask()
    d = np.array([j.d for j in robot.joints])
    d_total = np.where(rev[None, :], d[None, :], Q + d[None, :])            # (N, n)
    pts = [F[:, 0, :3, 3]]
    links = []
    for i in range(n):
        o_prev, z_prev = F[:, i, :3, 3], F[:, i, :3, 2]
        pts.append(o_prev + d_total[:, i, None] * z_prev)
        pts.append(F[:, i + 1, :3, 3])
        links += [i, i]
    pts.append(F[:, n + 1, :3, 3])
    links.append(n)
    if target is not None and target in robot.targets:
        T = F[:, n + 1]
        pts.append(T[:, :3, :3] @ robot.targets[target] + T[:, :3, 3])
        links.append(n)
    return np.stack(pts, axis=1), np.array(links, dtype=int)


def segment_distance(p1, q1, p2, q2) -> np.ndarray:
    """Shortest distance between segments [p1, q1] and [p2, q2] (arrays (..., 3)), vectorised
    (Ericson, Real-Time Collision Detection, 5.1.9)."""
    d1, d2, r = q1 - p1, q2 - p2, p1 - p2
    a = np.einsum("...i,...i->...", d1, d1)
    e = np.einsum("...i,...i->...", d2, d2)
    f = np.einsum("...i,...i->...", d2, r)
    c = np.einsum("...i,...i->...", d1, r)
    b = np.einsum("...i,...i->...", d1, d2)
    eps = 1e-12
    denom = a * e - b * b
    with np.errstate(divide="ignore", invalid="ignore"):
        s = np.where(denom > eps, np.clip((b * f - c * e) / np.where(denom > eps, denom, 1.0), 0.0, 1.0), 0.0)
        t = np.where(e > eps, (b * s + f) / np.where(e > eps, e, 1.0), 0.0)
        # t outside [0, 1]: clamp and recompute s
        t_c = np.clip(t, 0.0, 1.0)
        s = np.where(t != t_c, np.where(a > eps, np.clip((t_c * b - c) / np.where(a > eps, a, 1.0), 0.0, 1.0), 0.0), s)
    t = t_c
    c1 = p1 + s[..., None] * d1
    c2 = p2 + t[..., None] * d2
    return np.linalg.norm(c1 - c2, axis=-1)


def collision_radii(robot: RobotModel) -> np.ndarray | None:
    """Per-link capsule radii (n + 1, tool last) from the model, or None if it gives none."""
    r = getattr(robot, "collision_radius", None)
    if r is None:
        return None
    r = np.asarray(r, dtype=float).reshape(-1)
    if len(r) == robot.dof:
        r = np.append(r, r[-1])
    if len(r) != robot.dof + 1:
        raise RoboCalError(f"the robot model gives {len(r)} collision radii for {robot.dof} joints",
                           field="collision.radius",
                           hint=f"Give {robot.dof} radii (or {robot.dof + 1} with the tool).")
    return r


def _collision_pairs(robot: RobotModel, target: str | None, radii: np.ndarray):
    """Segment pairs to test: those whose chain distance exceeds the sum of their radii."""
    pts, links = arm_polyline(robot, np.zeros((1, robot.dof)), target)
    seg_len = np.linalg.norm(np.diff(pts[0], axis=0), axis=1)
    keep = np.flatnonzero(seg_len > 1e-6)                      # zero-length pieces add nothing
    r = radii[links]
    pairs = []
    for x, a in enumerate(keep):
        for b in keep[x + 1:]:
            between = seg_len[a + 1:b].sum()
            if links[a] != links[b] and between > r[a] + r[b]:
                pairs.append((a, b))
    return np.array(pairs, dtype=int).reshape(-1, 2), r


def self_collision(robot: RobotModel, Q, target: str | None = "marker",
                   radii: np.ndarray | None = None) -> np.ndarray:
    """(N,) True where two non-neighbouring capsules of the arm intersect (see module doc).
    All False when the model gives no radii. (Prismatic joints change segment lengths; the
    pairs are chosen at q = 0.)"""
    Q = np.atleast_2d(np.asarray(Q, dtype=float))
    radii = collision_radii(robot) if radii is None else np.asarray(radii, dtype=float)
    if radii is None:
        return np.zeros(len(Q), dtype=bool)
    pairs, r = _collision_pairs(robot, target, radii)
    if len(pairs) == 0:
        return np.zeros(len(Q), dtype=bool)
    pts, _ = arm_polyline(robot, Q, target)
    a, b = pairs[:, 0], pairs[:, 1]
    dist = segment_distance(pts[:, a], pts[:, a + 1], pts[:, b], pts[:, b + 1])   # (N, P)
    return np.any(dist < (r[a] + r[b])[None, :], axis=1)


def below_floor(robot: RobotModel, Q, floor: float, clearance: float = FLOOR_CLEARANCE,
                target: str | None = "marker") -> np.ndarray:
    """(N,) True where a point of the arm after the base, or the target, comes closer than
    `clearance` to the plane z = `floor` of the robot base frame (mm)."""
    pts, _ = arm_polyline(robot, Q, target)
    base_inv = tf.invert(robot.base)
    z = np.einsum("j,nkj->nk", base_inv[2, :3], pts[:, 1:]) + base_inv[2, 3]
    return np.any(z < floor + clearance, axis=1)


# -- sampling -------------------------------------------------------------------------------
def generate_candidates(robot: RobotModel, count: int, *, seed: int = 0, margin=DEFAULT_MARGIN_DEG,
                        rig: StereoRig | None = None, plate_size=None, target: str = "marker",
                        visibility: VisibilityOptions | None = None, floor: float | None = None,
                        floor_clearance: float = FLOOR_CLEARANCE, collision: bool = True,
                        max_draws: int | None = None, progress=None, cancelled=None) -> CandidateSet:
    """Up to `count` feasible configurations (see module doc), seeded. Stops drawing after
    `max_draws` (default max(250·count, 20000)) configurations; the set may then be smaller
    than `count` (an empty set is returned, not an error: callers say what to change)."""
    if count < 1:
        raise RoboCalError(f"the number of candidates must be at least 1, got {count}")
    if rig is not None and plate_size is None:
        raise RoboCalError("the marker plate size is needed for the visibility check",
                           hint="Give the plate size (mm) with the stereo rig.")
    if target not in robot.targets:
        raise RoboCalError(f"the robot '{robot.name}' has no target '{target}'",
                           hint="Add it to the robot model's targets (e.g. \"marker\": [0, 0, 25]).")
    monitor = Monitor(progress, cancelled)
    lo, hi = robot.sampling_range(margin)
    rng = np.random.default_rng(seed)
    radii = collision_radii(robot) if collision else None
    vis_opts = (visibility or VisibilityOptions()).as_kwargs()
    max_draws = int(max_draws if max_draws is not None else max(MAX_DRAWS_PER_CANDIDATE * count, MIN_DRAWS))
    rejected = {k: 0 for k in REJECT_ORDER}
    kept_Q, kept_depth = [], []
    n_kept = drawn = 0
    while n_kept < count and drawn < max_draws:
        monitor.step(max(n_kept / count, drawn / max_draws),
                     f"candidate poses: {n_kept} of {count} ({drawn} drawn)")
        m = min(BATCH, max_draws - drawn)
        Q = rng.uniform(lo, hi, size=(m, robot.dof))
        Q = robot.q_from_file(np.round(robot.q_to_file(Q), 3)).reshape(m, robot.dof)
        code, depth = _reject_codes(robot, Q, radii, floor, floor_clearance, rig, plate_size, target, vis_opts)
        ok = np.flatnonzero(code < 0)
        take = ok[: count - n_kept]
        # configurations after the last one needed count as not drawn
        stop = int(take[-1]) + 1 if len(take) == count - n_kept else m
        drawn += stop
        for k, reason in enumerate(REJECT_ORDER):
            rejected[reason] += int(np.sum(code[:stop] == k))
        kept_Q.append(Q[take])
        if depth is not None:
            kept_depth.append(depth[take])
        n_kept += len(take)
    Q = np.concatenate(kept_Q) if kept_Q else np.zeros((0, robot.dof))
    constraints = [f"joint limits minus {np.round(np.broadcast_to(np.asarray(margin, float), (robot.dof,)), 3).tolist()}"
                   " (deg / mm) margins"]
    if radii is not None:
        constraints.append("capsule self-collision")
    if floor is not None:
        constraints.append(f"floor at z = {floor:g} mm (base frame) + {floor_clearance:g} mm")
    if rig is not None:
        constraints.append("marker visible to both cameras ({margin:g} px margin, ≤ {max_angle_deg:g}°, "
                           "{min_depth:g}–{max_depth:g} mm)".format(**vis_opts))
    monitor.step(1.0, f"candidate poses: {len(Q)} ({drawn} drawn)")
    return CandidateSet(Q=Q, marker=robot.target_positions(Q, target) if len(Q) else np.zeros((0, 3)),
                        depth=(np.concatenate(kept_depth) if kept_depth else np.zeros(0)) if rig is not None else None,
                        drawn=drawn, rejected=rejected, lower=lo, upper=hi, target=target,
                        constraints=constraints, wanted=count)


def _reject_codes(robot, Q, radii, floor, clearance, rig, plate_size, target, vis_opts):
    """Per configuration the index in REJECT_ORDER of the first failed constraint (−1: kept),
    and the marker depth in the left camera frame (None without a rig)."""
    code = np.full(len(Q), -1, dtype=int)

    def mark(k, bad):
        code[(code < 0) & bad] = k

    if radii is not None:
        mark(0, self_collision(robot, Q, target, radii))
    if floor is not None:
        mark(1, below_floor(robot, Q, floor, clearance, target))
    depth = None
    if rig is not None:
        v = marker_visibility(Q, robot, rig, plate_size, target=target, **vis_opts)
        mark(2, ~(v.in_left & v.in_right))
        mark(3, ~v.facing)
        mark(4, ~v.depth_ok)
        depth = v.depth
    return code, depth


def no_candidate_error(cands: CandidateSet, robot: RobotModel, *, with_rig: bool) -> RoboCalError:
    """The message when no configuration passed the constraints: the main reason and what to change."""
    counts = ", ".join(f"{k}: {v}" for k, v in cands.rejected.items() if v)
    if with_rig and (cands.rejected[REJECT_IMAGE] + cands.rejected[REJECT_FACING] + cands.rejected[REJECT_DEPTH]) > 0:
        return RoboCalError(
            f"no candidate pose puts the marker in view of both cameras ({cands.drawn} drawn; {counts})",
            hint="Check the robot base pose in robot.json (it must be given in the left camera frame) "
                 "and the margins.")
    return RoboCalError(f"no candidate pose passes the constraints ({cands.drawn} drawn; {counts})",
                        hint="Reduce the joint margins, or check the collision radii and the floor height.")
