"""Robot kinematics: the DH model of the chapter's eq. (1)–(3), with Hayati's β.

Per joint, A = Rz(θ) · Tz(d) · Tx(a) · Rx(α) · Ry(β)  (eq. 1, plus Hayati's rotation).
For a revolute joint θ = q + theta; for a prismatic joint d = q + d.
The tool pose in the world (measurement) frame is  T = base · A1 · … · An · tool  (eq. 2–3).
With joint compliance (core.robot.compliance) every A_i is taken at q + δq(q): the joint angles
the arm really stands at under its own weight, for the joint values q the controller reports.

Internally lengths are mm and angles radians; robot files and joint CSVs use degrees.
"""
from __future__ import annotations

import copy
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from core.robot.compliance import Compliance


REVOLUTE = "revolute"
PRISMATIC = "prismatic"
PARALLEL_DEG = 5.0        # consecutive axes within this angle are "nearly parallel" (Hayati's β replaces d)
#: the one tool of a robot file without a "tools" section (it carries every target)
DEFAULT_TOOL = "tool"


@dataclass
class Joint:
    """One DH row. Angles in rad, lengths in mm. `min`/`max` limit the joint value q
    (rad for revolute, mm for prismatic)."""

    type: str = REVOLUTE
    theta: float = 0.0
    d: float = 0.0
    a: float = 0.0
    alpha: float = 0.0
    beta: float = 0.0
    min: float = -np.pi
    max: float = np.pi
    name: str = ""

    @property
    def revolute(self) -> bool:
        return self.type == REVOLUTE


@dataclass
class RobotModel:
    """A serial robot: DH joints, base pose in the world frame, tool pose in the flange
    frame, and named target points (mm) in the tool frame.

    `tools` (optional): for a tool changer, each tool's name and the targets it carries (every
    target on exactly one tool); empty for a robot with one tool (DEFAULT_TOOL, all targets).

    `collision_radius` (optional, mm): one capsule radius per link (n values; n + 1 with the
    tool link last) for the self-collision check of pose selection (core.poses.candidates);
    None when the robot file gives no "collision" section."""

    name: str
    joints: list[Joint]
    base: np.ndarray = field(default_factory=lambda: np.eye(4))
    tool: np.ndarray = field(default_factory=lambda: np.eye(4))
    targets: dict[str, np.ndarray] = field(default_factory=dict)
    calibration: dict | None = None
    collision_radius: np.ndarray | None = None
    tools: dict[str, list[str]] = field(default_factory=dict)
    # orientation (3x3) of a target's frame in the tool frame, where it matters (a marker whose
    # orientation is measured); a target absent here is aligned with the tool frame
    target_rotations: dict[str, np.ndarray] = field(default_factory=dict)
    # the gravity-shaped joint deflection (core.robot.compliance); None: a rigid arm
    compliance: Compliance | None = None

    @property
    def dof(self) -> int:
        return len(self.joints)

    # -- tools -------------------------------------------------------------------------
    def tool_map(self) -> dict[str, list[str]]:
        """Each tool's name and its targets (one tool, DEFAULT_TOOL, with every target when the
        robot file names no tools)."""
        if self.tools:
            return {k: list(v) for k, v in self.tools.items()}
        return {DEFAULT_TOOL: list(self.targets)}

    def tool_names(self) -> list[str]:
        return list(self.tool_map())

    def tool_targets(self, tool: str) -> list[str]:
        """The targets `tool` carries. Raises RoboCalError for a tool the robot does not define."""
        from core.errors import RoboCalError

        tools = self.tool_map()
        if tool not in tools:
            raise RoboCalError(f"the robot '{self.name}' has no tool '{tool}'",
                               hint=f"Choose one of its tools: {', '.join(tools)}.")
        return tools[tool]

    def tool_of(self, target: str) -> str:
        """The tool that carries `target` ("" when none does)."""
        return next((name for name, targets in self.tool_map().items() if target in targets), "")

    def copy(self) -> "RobotModel":
        return copy.deepcopy(self)

    # -- units -------------------------------------------------------------------------
    def revolute_mask(self) -> np.ndarray:
        return np.array([j.revolute for j in self.joints])

    def q_from_file(self, q_file) -> np.ndarray:
        """Joint values from file units (deg / mm) to internal (rad / mm); (..., n)."""
        q = np.array(q_file, dtype=float)
        return np.where(self.revolute_mask(), np.deg2rad(q), q)

    def q_to_file(self, q) -> np.ndarray:
        q = np.array(q, dtype=float)
        return np.where(self.revolute_mask(), np.rad2deg(q), q)

    def limits(self) -> tuple[np.ndarray, np.ndarray]:
        return (np.array([j.min for j in self.joints]), np.array([j.max for j in self.joints]))

    def sampling_range(self, margin=0.0) -> tuple[np.ndarray, np.ndarray]:
        """Joint limits shrunk by `margin` (file units: deg for revolute joints, mm for
        prismatic; a scalar or one per joint), revolute ranges clipped to ±180°; internal
        units. Raises RoboCalError when a margin leaves no range."""
        from core.errors import RoboCalError

        lo, hi = self.limits()
        rev = self.revolute_mask()
        m = np.broadcast_to(np.asarray(margin, dtype=float), (self.dof,))
        if np.any(m < 0):
            raise RoboCalError("joint margins must not be negative", hint="Give margins of 0 or more degrees.")
        m_int = np.where(rev, np.deg2rad(m), m)
        lo = np.where(rev, np.maximum(lo, -np.pi), lo) + m_int
        hi = np.where(rev, np.minimum(hi, np.pi), hi) - m_int
        bad = np.flatnonzero(lo >= hi)
        if len(bad):
            i = int(bad[0])
            j = self.joints[i]
            unit = "°" if j.revolute else " mm"
            width = (np.rad2deg(j.max - j.min) if j.revolute else j.max - j.min)
            raise RoboCalError(f"a joint margin of {m[i]:g}{unit} leaves no range for joint {i + 1} "
                               f"(its limits span {width:g}{unit})",
                               hint=f"Use a margin smaller than {width / 2:g}{unit}.")
        return lo, hi

    def within_limits(self, q, margin: float = 0.0) -> np.ndarray:
        """True where every joint value of q (..., n) lies inside its limits (internal units)."""
        lo, hi = self.limits()
        q = np.asarray(q, dtype=float)
        return np.all((q >= lo + margin) & (q <= hi - margin), axis=-1)

    # -- forward kinematics --------------------------------------------------------------
    def dh_arrays(self) -> dict[str, np.ndarray]:
        return {k: np.array([getattr(j, k) for j in self.joints], dtype=float)
                for k in ("theta", "d", "a", "alpha", "beta")}

    def deflected(self, Q) -> np.ndarray:
        """The joint values the arm stands at, q + δq(q) with its compliance (Q itself for a rigid
        arm): Q (N, n) -> (N, n), internal units."""
        Q = np.atleast_2d(np.asarray(Q, dtype=float))
        if self.compliance is None:
            return Q
        return Q + np.where(self.revolute_mask(), self.compliance.deflection(Q), 0.0)

    def joint_transforms(self, Q) -> np.ndarray:
        """A_i for every configuration, deflection included: Q (N, n) -> (N, n, 4, 4)."""
        Q = self.deflected(Q)
        p = self.dh_arrays()
        rev = self.revolute_mask()
        theta = np.where(rev, Q + p["theta"], p["theta"])
        d = np.where(rev, p["d"], Q + p["d"])
        return dh_matrices(theta, d, p["a"], p["alpha"], p["beta"])

    def frames_many(self, Q) -> np.ndarray:
        """World poses of base, each joint frame and the tool: (N, n + 2, 4, 4).

        Index 0 is the base frame, index i (1..n) the frame after joint i, index n + 1
        the tool frame."""
        A = self.joint_transforms(Q)
        N, n = A.shape[:2]
        out = np.empty((N, n + 2, 4, 4))
        out[:, 0] = self.base
        for i in range(n):
            out[:, i + 1] = out[:, i] @ A[:, i]
        out[:, n + 1] = out[:, n] @ self.tool
        return out

    def fk_many(self, Q) -> np.ndarray:
        """Tool poses in the world frame, Q (N, n) -> (N, 4, 4)."""
        A = self.joint_transforms(Q)
        T = np.broadcast_to(self.base, (A.shape[0], 4, 4)).copy()
        for i in range(A.shape[1]):
            T = T @ A[:, i]
        return T @ self.tool

    def fk(self, q) -> np.ndarray:
        """Tool pose (4x4) in the world frame for one configuration (internal units)."""
        return self.fk_many(np.asarray(q, dtype=float)[None, :])[0]

    def target_positions(self, Q, target: str) -> np.ndarray:
        """World positions (mm) of a named target: Q (N, n) -> (N, 3)."""
        T = self.fk_many(Q)
        p = self.targets[target]
        return T[:, :3, :3] @ p + T[:, :3, 3]

    def target_position(self, q, target: str) -> np.ndarray:
        return self.target_positions(np.asarray(q, dtype=float)[None, :], target)[0]

    def parallel_axis_joints(self, tolerance_deg: float = PARALLEL_DEG) -> list[int]:
        """0-based indices i of the joints whose axis is nearly parallel to the next one's
        (|sin α| of joint i small): joint i gets Hayati's β, which replaces its own
        ill-conditioned d (`J{i+1}.d`, kept at nominal); the next joint's d takes up the real
        offset along the axes."""
        tol = np.sin(np.deg2rad(tolerance_deg))
        return [i for i, j in enumerate(self.joints[:-1]) if abs(np.sin(j.alpha)) < tol]


def dh_matrices(theta, d, a, alpha, beta=None) -> np.ndarray:
    """Rz(θ)·Tz(d)·Tx(a)·Rx(α)·Ry(β) for broadcastable arrays -> (..., 4, 4)."""
    theta, d, a, alpha = np.broadcast_arrays(*(np.asarray(v, dtype=float) for v in (theta, d, a, alpha)))
    ct, st, ca, sa = np.cos(theta), np.sin(theta), np.cos(alpha), np.sin(alpha)
    T = np.zeros(theta.shape + (4, 4))
    T[..., 0, 0], T[..., 0, 1], T[..., 0, 2], T[..., 0, 3] = ct, -st * ca, st * sa, a * ct
    T[..., 1, 0], T[..., 1, 1], T[..., 1, 2], T[..., 1, 3] = st, ct * ca, -ct * sa, a * st
    T[..., 2, 1], T[..., 2, 2], T[..., 2, 3] = sa, ca, d
    T[..., 3, 3] = 1.0
    if beta is not None:
        beta = np.broadcast_to(np.asarray(beta, dtype=float), theta.shape)
        if np.any(beta != 0.0):
            cb, sb = np.cos(beta), np.sin(beta)
            Ry = np.zeros(theta.shape + (3, 3))
            Ry[..., 0, 0], Ry[..., 0, 2], Ry[..., 1, 1], Ry[..., 2, 0], Ry[..., 2, 2] = cb, sb, 1.0, -sb, cb
            T[..., :3, :3] = T[..., :3, :3] @ Ry
    return T


def robot_path(name: str) -> Path:
    """Path of a preset robot file in resources/robots (name without .json)."""
    from core.resources import resource_path
    return resource_path("robots", f"{name}.json")


def preset_names() -> list[str]:
    from core.resources import resource_path
    return sorted(p.stem for p in resource_path("robots").glob("*.json"))
