"""Joint compliance: the gravity-shaped deflection of the joints that carry a vertical arm.

An industrial arm bends under its own weight (and its payload): the shoulder (J2) and elbow
(J3) gears and links give a little under the gravity torque they carry, so the arm stands
at slightly different joint angles than the encoders report. The torque at J2 follows the
horizontal lever of the upper arm (angle q2) and of the forearm (angle q2 + q3); the torque
at J3 that of the forearm alone. The deflection is modelled as a joint-angle correction

    δq_j = Σ_k c_jk · f_k(q)        f = (sin q2, cos q2, sin(q2 + q3), cos(q2 + q3))

(q the joint values the controller reports, rad; c_jk rad, files: degrees), added to the joint
values inside forward kinematics: the arm is where the rigid model puts it at q + δq. A sine
and a cosine of the same angle together take any phase, so the joints' zero offsets and the
centres of mass off the link axes need no own parameters. The default terms are the six the
physics asks for: J2 all four shapes, J3 the forearm's two.

The shapes are defined for a vertical articulated arm only: J1's axis along gravity (floor or
ceiling mounted), J2 and J3 revolute with axes perpendicular to it and parallel to each other,
so the arm's vertical plane turns with J1 and the gravity torques depend on q2 and q2 + q3
alone. `check_vertical_arm` refuses other robots with a message.

The coefficients hold for the payload mounted during calibration (recorded in the calibration
section): a heavier tool bends the arm more.

For inverse kinematics with a model that has compliance: the commanded q must satisfy
FK_rigid(q + δq(q)) = target; its Jacobian is J_rigid(q + δq)·(I + ∂δq/∂q), with ∂δq/∂q from
`Compliance.derivative`.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from core.errors import RoboCalError

FORMAT_FAMILY = "robocal.compliance"
FORMAT_MAJOR = 1
FORMAT = f"{FORMAT_FAMILY}/{FORMAT_MAJOR}"
#: the shape functions f_k, in this order
SHAPES = ("sin_q2", "cos_q2", "sin_q23", "cos_q23")
#: the terms identification estimates: (0-based joint, shape) — J2 carries upper arm and
#: forearm, J3 the forearm
DEFAULT_TERMS = tuple([(1, s) for s in SHAPES] + [(2, "sin_q23"), (2, "cos_q23")])
#: the gravity direction in the robot's base frame when none is given (floor mounted)
DEFAULT_GRAVITY = (0.0, 0.0, -1.0)
#: J1 within this angle of gravity, J2/J3 within this of perpendicular to it, J2 ∥ J3 within this
AXIS_TOLERANCE_DEG = 5.0


@dataclass
class Compliance:
    """The deflection terms of a robot: `coefficients` (n, 4) rad per unit shape value, one row
    per joint, columns in SHAPES order; `terms` the (joint, shape) pairs the model holds (the
    others are zero); `gravity` the unit gravity direction in the robot's base frame."""

    coefficients: np.ndarray
    terms: tuple[tuple[int, str], ...] = DEFAULT_TERMS
    gravity: np.ndarray = field(default_factory=lambda: np.array(DEFAULT_GRAVITY))

    @classmethod
    def zero(cls, dof: int, terms=DEFAULT_TERMS, gravity=DEFAULT_GRAVITY) -> "Compliance":
        return cls(np.zeros((dof, len(SHAPES))), tuple(terms), np.asarray(gravity, dtype=float))

    def copy(self) -> "Compliance":
        return Compliance(self.coefficients.copy(), tuple(self.terms), self.gravity.copy())

    def coefficient(self, joint: int, shape: str) -> float:
        return float(self.coefficients[joint, SHAPES.index(shape)])

    def set(self, joint: int, shape: str, value: float) -> None:
        self.coefficients[joint, SHAPES.index(shape)] = value

    def with_terms(self, terms) -> "Compliance":
        """A copy holding also `terms` (at their current values, zero when new)."""
        out = self.copy()
        out.terms = tuple(dict.fromkeys(tuple(self.terms) + tuple(terms)))
        return out

    @staticmethod
    def shapes(Q) -> np.ndarray:
        """f(q) for configurations Q (N, n), rad -> (N, 4)."""
        Q = np.atleast_2d(np.asarray(Q, dtype=float))
        q2, q23 = Q[:, 1], Q[:, 1] + Q[:, 2]
        return np.stack([np.sin(q2), np.cos(q2), np.sin(q23), np.cos(q23)], axis=1)

    def deflection(self, Q) -> np.ndarray:
        """δq (N, n), rad, for configurations Q (N, n)."""
        return self.shapes(Q) @ self.coefficients.T

    def derivative(self, Q) -> np.ndarray:
        """∂δq/∂q (N, n, n): row j, column i is ∂δq_j/∂q_i (only q2 and q3 columns are non-zero)."""
        Q = np.atleast_2d(np.asarray(Q, dtype=float))
        N, n = Q.shape
        q2, q23 = Q[:, 1], Q[:, 1] + Q[:, 2]
        # ∂f/∂q2 and ∂f/∂q3, (N, 4) each
        d2 = np.stack([np.cos(q2), -np.sin(q2), np.cos(q23), -np.sin(q23)], axis=1)
        d3 = np.stack([np.zeros(N), np.zeros(N), np.cos(q23), -np.sin(q23)], axis=1)
        out = np.zeros((N, n, n))
        out[:, :, 1] = d2 @ self.coefficients.T
        out[:, :, 2] = d3 @ self.coefficients.T
        return out

    @property
    def is_zero(self) -> bool:
        return not np.any(self.coefficients)


def check_vertical_arm(model, *, source=None, field: str = "compliance") -> None:
    """Refuse (RoboCalError) a robot on which the gravity shapes are undefined: fewer than three
    joints, a prismatic joint among J1–J3, J1 not along gravity, J2 not perpendicular to it,
    J3 not parallel to J2."""
    gravity = model.compliance.gravity if model.compliance is not None else np.array(DEFAULT_GRAVITY)
    hint = ("Deflection terms are defined for a vertical articulated arm (J1 vertical, J2 and J3 horizontal "
            "and parallel); identify this robot with --compliance off.")
    if model.dof < 3:
        raise RoboCalError(f"the robot '{model.name}' has {model.dof} joints: the deflection terms need a "
                           f"shoulder (J2) and an elbow (J3)", source=source, field=field, hint=hint)
    prismatic = [i + 1 for i in range(3) if not model.joints[i].revolute]
    if prismatic:
        raise RoboCalError(f"joint J{prismatic[0]} of '{model.name}' is prismatic: the deflection terms follow "
                           f"the angles of revolute J1–J3 and are undefined here", source=source, field=field,
                           hint=hint)
    F = model.frames_many(np.zeros((1, model.dof)))[0]
    world_from_base = model.base[:3, :3]
    axes = [world_from_base.T @ F[i, :3, 2] for i in range(3)]      # J1, J2, J3 axes in the base frame
    g = np.asarray(gravity, dtype=float)
    g = g / np.linalg.norm(g)
    tol = np.sin(np.deg2rad(AXIS_TOLERANCE_DEG))
    if np.linalg.norm(np.cross(axes[0], g)) > tol:
        raise RoboCalError(f"J1 of '{model.name}' is not vertical (its axis is {_deg(axes[0], g):.0f}° from "
                           f"gravity): the gravity torques would depend on J1 too", source=source, field=field,
                           hint=hint)
    if abs(float(axes[1] @ g)) > tol:
        raise RoboCalError(f"J2 of '{model.name}' is not horizontal (its axis is {_deg(axes[1], g):.0f}° from "
                           f"gravity): it carries no gravity torque of the arm", source=source, field=field,
                           hint=hint)
    if np.linalg.norm(np.cross(axes[1], axes[2])) > tol:
        raise RoboCalError(f"J3 of '{model.name}' is not parallel to J2: the forearm does not swing in the "
                           f"arm's vertical plane", source=source, field=field, hint=hint)


def _deg(u: np.ndarray, v: np.ndarray) -> float:
    return float(np.degrees(np.arccos(np.clip(abs(float(u @ v)) / np.linalg.norm(u) / np.linalg.norm(v), 0, 1))))
