"""The identification parameters g and the calibration Jacobian J_g (chapter eq. 5–7).

Parameter vector g
------------------
* per joint i (named `J1`, `J2`, … in robot order): `Ji.theta`, `Ji.d`, `Ji.a`, `Ji.alpha`, and
  `Ji.beta` when the joint's axis is nearly parallel to the next one (`RobotModel.
  parallel_axis_joints()`, i.e. α_i ≈ 0). With A_i = Rz(θ)·Tz(d)·Tx(a)·Rx(α)·Ry(β):

  Which d is ill-conditioned (Hayati). When the axes z_(i-1) (joint i) and z_i (joint i+1)
  are parallel, the DH common normal x_i between them can sit anywhere along the axes: d_i
  (the slide along z_(i-1) from x_(i-1) to that normal) is arbitrary, and a tilt of 0.01° makes
  the common normal of the now skew axes jump metres away, so d_i and d_(i+1) jump by equal and
  opposite amounts. With Hayati's β_i the frame i is instead placed where the axis of joint
  i+1 crosses the plane "z = d_i" of frame i−1 — a well-conditioned crossing because the axes
  are nearly parallel — so d_i becomes a free convention, not a property of the robot. We keep
  **d_i of the joint that gets β_i** at its nominal value (`Ji.d` beside `Ji.beta`, Hayati's own
  choice); d_(i+1) measures the real offset along the parallel axes. Example: for the 6R arm
  and the IRB 120 (axes 2 and 3 parallel) `J2.beta` is added and `J2.d` is kept fixed; for the
  UR5 (axes 2, 3, 4 parallel) `J2.beta`, `J3.beta` are added and `J2.d`, `J3.d` are fixed.
  (With the 0-based `parallel_axis_joints()` index i, this is `model.joints[i].d`.)

* the base pose in the measurement frame, 6 parameters: `base.x`, `base.y`, `base.z` move the
  base origin along the measurement frame's axes (mm); `base.rx`, `base.ry`, `base.rz` are small
  rotations (rad) about the measurement frame's x, y, z axes through the base origin, applied
  on the left: base ← [Exp(ω)·R | t + δt].
* one 3D offset per measured target, `<target>.x/.y/.z` (mm, in the tool frame). The tool
  transform itself stays fixed: the target points carry the tool offset.
* with compliance (core.robot.compliance), the deflection coefficients the model holds,
  `Ji.<shape>` (e.g. `J2.cos_q2`, rad per unit shape value): δq_i = Σ c_ik·f_k(q).
* with measured orientations (core.kinematics.orientation), the orientation of each such
  target's frame on the tool, `<target>.rx/.ry/.rz`: small rotations (rad) about the tool
  frame's axes, applied on the left of `RobotModel.target_rotations[target]`. They do not move
  points (zero columns here); their orientation rows are in core.kinematics.orientation.

Estimation works in corrections δg at the current model (the Jacobian is exact at δg = 0);
`apply_step` adds them (base rotation through the exponential map).

Jacobian (analytic, via the joint frames, world = measurement frame; P a measured point)
-----------------------------------------------------------------------------------------
    ∂P/∂θ_i = z_(i-1) × (P − o_(i-1))      ∂P/∂d_i = z_(i-1)
    ∂P/∂a_i = x'_i                          ∂P/∂α_i = x'_i × (P − o_i)
    ∂P/∂β_i = y_i × (P − o_i)
    ∂P/∂base.(x,y,z) = e_(x,y,z)             ∂P/∂base.r(x,y,z) = e_(x,y,z) × (P − o_0)
    ∂P/∂target = R_tool (columns: tool frame axes in the world)
    ∂P/∂c_ik = f_k(q) · z_(i-1) × (P − o_(i-1))   (a deflection coefficient turns joint i by f_k(q))
where frame i−1 is (z_(i-1), o_(i-1)), frame i is after A_i, x'_i = R_i·Ry(β_i)ᵀ·e_x is the x
axis before Hayati's rotation (the direction of a_i and of the α_i rotation), y_i = R_i·e_y.
Rows are stacked point by point: [x_0, y_0, z_0, x_1, …] (eq. 6–7: Φ).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Iterable, Sequence

import numpy as np

from core import transforms as tf
from core.errors import RoboCalError, UsageError
from core.robot.compliance import SHAPES, Compliance
from core.robot.model import RobotModel

JOINT_KINDS = ("theta", "d", "a", "alpha", "beta")
BASE_KINDS = ("x", "y", "z", "rx", "ry", "rz")
TARGET_KINDS = ("x", "y", "z")
ORIENTATION_KINDS = ("rx", "ry", "rz")
ANGULAR_KINDS = {"theta", "alpha", "beta", "rx", "ry", "rz"}
COMPLIANCE = "compliance"


@dataclass(frozen=True)
class Parameter:
    """One element of g. `joint` is the 0-based joint index (−1 otherwise)."""

    name: str
    group: str          # "joint" | "base" | "target" | "orientation" | "compliance"
    kind: str           # theta d a alpha beta | x y z rx ry rz | x y z | rx ry rz | a compliance shape
    joint: int = -1
    target: str = ""

    @property
    def angular(self) -> bool:
        return (self.kind in ANGULAR_KINDS and self.group != "target") or self.group == COMPLIANCE

    @property
    def unit(self) -> str:
        """Unit in files and on screen (internally angles are radians)."""
        return "deg" if self.angular else "mm"

    @property
    def to_display(self) -> float:
        """Factor from internal units to display units."""
        return float(np.rad2deg(1.0)) if self.angular else 1.0


def joint_label(i: int) -> str:
    """The name of joint i (0-based) in parameter names: J1, J2, …"""
    return f"J{i + 1}"


def hayati_joints(model: RobotModel) -> list[int]:
    """0-based joints that get Hayati's β (axis nearly parallel to the next); their d is fixed."""
    return list(model.parallel_axis_joints())


def all_parameters(model: RobotModel, targets: Sequence[str],
                   orientation_targets: Sequence[str] = (), compliance: bool = False) -> list[Parameter]:
    """The full parameter vector g for `model` with the measured `targets`, in a fixed order:
    joints (θ, d, a, α, β per joint), base (x, y, z, rx, ry, rz), targets (x, y, z each), then
    the orientation on the tool (rx, ry, rz) of each of `orientation_targets`, then (with
    `compliance`) the deflection terms of `model.compliance`."""
    for t in targets:
        if t == "base" or (t[:1] == "J" and t[1:].isdigit()):
            raise RoboCalError(f"the target name '{t}' clashes with a parameter group name",
                               hint="Rename the target in the robot model (e.g. 'marker').")
    beta = set(hayati_joints(model))
    params = []
    for i in range(model.dof):
        for kind in JOINT_KINDS:
            if kind == "beta" and i not in beta:
                continue
            params.append(Parameter(f"{joint_label(i)}.{kind}", "joint", kind, joint=i))
    params += [Parameter(f"base.{k}", "base", k) for k in BASE_KINDS]
    for t in targets:
        params += [Parameter(f"{t}.{k}", "target", k, target=t) for k in TARGET_KINDS]
    for t in orientation_targets:
        params += [Parameter(f"{t}.{k}", "orientation", k, target=t) for k in ORIENTATION_KINDS]
    if compliance and model.compliance is not None:
        params += [Parameter(f"{joint_label(j)}.{shape}", COMPLIANCE, shape, joint=j)
                   for j, shape in model.compliance.terms]
    return params


def resolve_names(names: Iterable[str], params: Sequence[Parameter], model: RobotModel) -> list[str]:
    """Canonical parameter names for user-given ones (`J2.a`, `base.rz`, `marker.x`; a joint's own
    name such as `shoulder.a` is accepted too; matching ignores case). Unknown names raise
    UsageError listing the valid ones."""
    by_lower = {p.name.lower(): p.name for p in params}
    for i, j in enumerate(model.joints):
        if j.name:
            for p in params:
                if p.joint == i:
                    by_lower.setdefault(f"{j.name}.{p.kind}".lower(), p.name)
    out = []
    for raw in names:
        name = raw.strip()
        if not name:
            continue
        key = name.lower()
        if key not in by_lower:
            valid = ", ".join(p.name for p in params)
            raise UsageError(f"unknown parameter '{name}' to fix",
                             hint=f"Valid names: {valid}.")
        out.append(by_lower[key])
    return list(dict.fromkeys(out))


# -- prediction and Jacobian ---------------------------------------------------------------
def _target_points(model: RobotModel, point_targets: Sequence[str]) -> np.ndarray:
    try:
        return np.array([model.targets[t] for t in point_targets], dtype=float).reshape(-1, 3)
    except KeyError as exc:
        raise RoboCalError(f"target '{exc.args[0]}' is not defined in the robot '{model.name}'",
                           hint="Add it to the robot model's 'targets' or fix the name.") from None


def predict_points(model: RobotModel, Q, point_targets: Sequence[str]) -> np.ndarray:
    """World positions (N, 3) of the points: Q (N, n) with one target name per row."""
    Q = np.atleast_2d(np.asarray(Q, dtype=float))
    T = model.fk_many(Q)
    p = _target_points(model, point_targets)
    return np.einsum("nij,nj->ni", T[:, :3, :3], p) + T[:, :3, 3]


def calibration_jacobian(model: RobotModel, Q, point_targets: Sequence[str],
                         params: Sequence[Parameter]) -> np.ndarray:
    """Analytic J_g stacked over points, Φ (3N, p): ∂(predicted point)/∂(correction of each
    parameter) at the current model. Vectorised over the configurations Q (N, n)."""
    Q = np.atleast_2d(np.asarray(Q, dtype=float))
    N, n = Q.shape
    F = model.frames_many(Q)                                  # (N, n + 2, 4, 4)
    tool = F[:, n + 1]
    p_tool = _target_points(model, point_targets)
    P = np.einsum("nij,nj->ni", tool[:, :3, :3], p_tool) + tool[:, :3, 3]
    beta = np.array([j.beta for j in model.joints])
    out = np.zeros((N, 3, len(params)))
    cache: dict = {}

    def joint_frames(i):
        if i not in cache:
            prev, cur = F[:, i], F[:, i + 1]
            z_prev, o_prev = prev[:, :3, 2], prev[:, :3, 3]
            R, o = cur[:, :3, :3], cur[:, :3, 3]
            x_pre = R @ np.array([np.cos(beta[i]), 0.0, np.sin(beta[i])])  # R_i · Ry(β)ᵀ · e_x
            cache[i] = (z_prev, o_prev, x_pre, R[:, :, 1], o)
        return cache[i]

    o_base = F[:, 0, :3, 3]
    eye = np.eye(3)
    shapes = None
    for k, prm in enumerate(params):
        if prm.group == COMPLIANCE:
            shapes = Compliance.shapes(Q) if shapes is None else shapes
            z_prev, o_prev, *_ = joint_frames(prm.joint)
            out[:, :, k] = shapes[:, SHAPES.index(prm.kind), None] * np.cross(z_prev, P - o_prev)
            continue
        if prm.group == "joint":
            z_prev, o_prev, x_pre, y_i, o_i = joint_frames(prm.joint)
            if prm.kind == "theta":
                col = np.cross(z_prev, P - o_prev)
            elif prm.kind == "d":
                col = z_prev
            elif prm.kind == "a":
                col = x_pre
            elif prm.kind == "alpha":
                col = np.cross(x_pre, P - o_i)
            else:  # beta
                col = np.cross(y_i, P - o_i)
        elif prm.group == "base":
            axis = eye["xyz".index(prm.kind[-1])]
            col = np.broadcast_to(axis, (N, 3)) if len(prm.kind) == 1 else np.cross(axis, P - o_base)
        elif prm.group == "orientation":
            continue                        # turns the target's frame, not its point
        else:
            col = tool[:, :3, "xyz".index(prm.kind)] * np.array(
                [t == prm.target for t in point_targets], dtype=float)[:, None]
        out[:, :, k] = col
    return out.reshape(3 * N, len(params))


# -- applying corrections ------------------------------------------------------------------
def log_so3(R: np.ndarray) -> np.ndarray:
    """Rotation vector of a rotation matrix."""
    from scipy.spatial.transform import Rotation
    return Rotation.from_matrix(R).as_rotvec()


def apply_step(model: RobotModel, params: Sequence[Parameter], delta) -> RobotModel:
    """A copy of `model` with the corrections `delta` (internal units) applied."""
    out = model.copy()
    delta = np.asarray(delta, dtype=float)
    omega = np.zeros(3)
    shift = np.zeros(3)
    turns: dict[str, np.ndarray] = {}
    for prm, dv in zip(params, delta):
        if dv == 0.0:
            continue
        if prm.group == "joint":
            j = out.joints[prm.joint]
            setattr(j, prm.kind, getattr(j, prm.kind) + dv)
        elif prm.group == "base":
            if len(prm.kind) == 1:
                shift["xyz".index(prm.kind)] += dv
            else:
                omega["xyz".index(prm.kind[1])] += dv
        elif prm.group == "orientation":
            turns.setdefault(prm.target, np.zeros(3))["xyz".index(prm.kind[1])] += dv
        elif prm.group == COMPLIANCE:
            out.compliance.set(prm.joint, prm.kind, out.compliance.coefficient(prm.joint, prm.kind) + dv)
        else:
            t = out.targets[prm.target].astype(float).copy()
            t["xyz".index(prm.kind)] += dv
            out.targets[prm.target] = t
    for name, w in turns.items():
        out.target_rotations[name] = tf.rot_vec(w) @ out.target_rotations.get(name, np.eye(3))
    if np.any(omega) or np.any(shift):
        base = out.base.copy()
        base[:3, :3] = tf.rot_vec(omega) @ base[:3, :3]
        base[:3, 3] = base[:3, 3] + shift
        out.base = base
    return out


def parameter_difference(a: RobotModel, b: RobotModel, params: Sequence[Parameter]) -> np.ndarray:
    """δg such that apply_step(b, params, δg) ≈ a (exact for joints/targets; base rotation as the
    rotation vector of R_a·R_bᵀ). Internal units."""
    out = np.zeros(len(params))
    omega = log_so3(a.base[:3, :3] @ b.base[:3, :3].T)
    eye = np.eye(3)
    for k, prm in enumerate(params):
        if prm.group == "joint":
            out[k] = getattr(a.joints[prm.joint], prm.kind) - getattr(b.joints[prm.joint], prm.kind)
        elif prm.group == "base":
            if len(prm.kind) == 1:
                out[k] = a.base["xyz".index(prm.kind), 3] - b.base["xyz".index(prm.kind), 3]
            else:
                out[k] = omega["xyz".index(prm.kind[1])]
        elif prm.group == COMPLIANCE:
            out[k] = compliance_value(a, prm) - compliance_value(b, prm)
        elif prm.group == "orientation":
            turn = log_so3(a.target_rotations.get(prm.target, eye) @ b.target_rotations.get(prm.target, eye).T)
            out[k] = turn["xyz".index(prm.kind[1])]
        else:
            i = "xyz".index(prm.kind)
            out[k] = a.targets[prm.target][i] - b.targets[prm.target][i]
    return out


def compliance_value(model: RobotModel, prm: Parameter) -> float:
    """The deflection coefficient `prm` of `model` (rad; 0 for a rigid model)."""
    return 0.0 if model.compliance is None else model.compliance.coefficient(prm.joint, prm.kind)


def expand_poses(Q_poses, targets: Sequence[str]) -> tuple[np.ndarray, list[str]]:
    """Every pose × every target: (N·T, n) configurations and the target name of each point."""
    Q_poses = np.atleast_2d(np.asarray(Q_poses, dtype=float))
    Q = np.repeat(Q_poses, len(targets), axis=0)
    names = [t for _ in range(len(Q_poses)) for t in targets]
    return Q, names


def display_value(model: RobotModel, prm: Parameter) -> float:
    """The value of parameter `prm` of `model` as the parameter table shows it (mm / deg; the
    base as its origin and roll, pitch, yaw)."""
    if prm.group == "joint":
        return getattr(model.joints[prm.joint], prm.kind) * prm.to_display
    if prm.group == "target":
        return float(model.targets[prm.target]["xyz".index(prm.kind)])
    if prm.group == COMPLIANCE:        # degrees of joint deflection per unit shape value
        return float(np.rad2deg(compliance_value(model, prm))) + 0.0
    if prm.group == "orientation":     # the rotation vector of the marker's orientation on the tool
        R = model.target_rotations.get(prm.target, np.eye(3))
        return float(np.rad2deg(log_so3(R)["xyz".index(prm.kind[1])])) + 0.0
    xyz, rpy = tf.matrix_to_pose(model.base)
    if len(prm.kind) == 1:
        return float(xyz["xyz".index(prm.kind)]) + 0.0
    return float(np.rad2deg(rpy["xyz".index(prm.kind[1])])) + 0.0   # + 0.0: no "-0.0" on screen
