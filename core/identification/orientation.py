"""Orientation residuals for identification: the measured marker frame against the model's.

The model's predicted frame and its Jacobian rows are in core.kinematics.orientation. The residual
of a point is the rotation vector e = log(R_measured · Rᵀ) (rad, measurement frame), weighted by
the measured standard deviations about the measurement frame's axes; a parameter change that
turns the predicted frame by ω changes it to e − ω to first order.

Why it matters: a marker on the last joint's axis does not move when that joint turns, so the
points alone cannot tell its zero (`J6.theta` of a 6-axis arm); its measured frame does turn.
The marker's own orientation on the flange turns the frame the same way, so the joint's zero
is determined only when the marker's turn about the last axis is known (`--fix marker.rz`:
the marker mounted with its printed x axis along a known flange direction); the tilts
`marker.rx`, `marker.ry` can stay estimated.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np
from scipy.spatial.transform import Rotation

from core.errors import RoboCalError
from core.kinematics.orientation import predict_rotations
from core.measurement.file import Measurements
from core.robot.model import RobotModel


def orientation_residuals(model: RobotModel, meas: Measurements) -> np.ndarray:
    """(N, 3) rotation vectors log(R_measured·R_predictedᵀ) (rad); zero where a point has no
    measured orientation."""
    out = np.zeros((meas.n_points, 3))
    has = meas.has_orientation
    if has.any():
        R_m = Rotation.from_rotvec(meas.rotation[has]).as_matrix()
        R_p = predict_rotations(model, meas.Q[has], [t for t, h in zip(meas.target, has) if h])
        out[has] = Rotation.from_matrix(R_m @ np.transpose(R_p, (0, 2, 1))).as_rotvec()
    return out


def orientation_weights(meas: Measurements) -> np.ndarray:
    """(N, 3) weights 1/σ² (rad⁻²) of the orientation residuals; zero where there are none."""
    out = np.zeros((meas.n_points, 3))
    has = meas.has_orientation
    out[has] = 1.0 / meas.rotation_sigma[has] ** 2
    return out


def orientation_targets(meas: Measurements) -> list[str]:
    """The targets with at least one measured orientation, in order of first appearance."""
    has = meas.has_orientation
    return list(dict.fromkeys(t for t, h in zip(meas.target, has) if h))


def require_orientations(meas: Measurements) -> list[str]:
    """`orientation_targets`, or a RoboCalError when the file has none or no position sigmas
    (needed to weigh positions against orientations)."""
    targets = orientation_targets(meas)
    if not targets:
        raise RoboCalError("the measurements carry no orientations (columns rx, ry, rz, srx, sry, srz)",
                           source=meas.source or None,
                           hint="Measure again with the measurement step (it records the marker's orientation), "
                                "or identify without orientation.")
    if meas.sigma is None:
        raise RoboCalError("orientations are used only with the positions' standard deviations (sx, sy, sz): "
                           "they weigh millimetres against degrees", source=meas.source or None,
                           hint="Use a measurements file with sx, sy, sz, or identify without orientation.")
    return targets


def with_measured_rotations(model: RobotModel, meas: Measurements, targets: Sequence[str]) -> RobotModel:
    """A copy of `model` whose `target_rotations` of `targets` are the chordal mean of
    R_toolᵀ·R_measured over the points (the start of the estimate)."""
    out = model.copy()
    has = meas.has_orientation
    T = model.fk_many(meas.Q)
    R_m = Rotation.from_rotvec(np.where(has[:, None], meas.rotation, 0.0)).as_matrix()
    for t in targets:
        sel = has & np.array([x == t for x in meas.target])
        M = np.einsum("nji,njk->ik", T[sel, :3, :3], R_m[sel])
        U, _, Vt = np.linalg.svd(M)
        out.target_rotations[t] = U @ np.diag([1.0, 1.0, np.sign(np.linalg.det(U @ Vt)) or 1.0]) @ Vt
    return out


def orientation_errors_deg(model: RobotModel, meas: Measurements) -> np.ndarray:
    """Angles (deg) between measured and predicted marker frames, for the points that have one."""
    return np.rad2deg(np.linalg.norm(orientation_residuals(model, meas)[meas.has_orientation], axis=1))


def rms(values: np.ndarray) -> float:
    return float(np.sqrt(np.mean(np.square(values)))) if len(values) else float("nan")


@dataclass
class OrientationReport:
    """What the measured orientations did in an identification (angles in degrees)."""

    targets: list[str]                 # targets whose orientation on the tool was estimated
    n_points: int                      # fitted points with a measured orientation
    rms_before_deg: float              # nominal geometry, base registered, marker orientation from the data
    rms_after_deg: float
    determined: list[str]              # parameters estimated only thanks to the orientations
    holdout_rms_before_deg: float | None = None
    holdout_rms_after_deg: float | None = None

    def summary(self) -> dict:
        out = {"targets": list(self.targets), "n_points": self.n_points, "rms_before_deg": self.rms_before_deg,
               "rms_after_deg": self.rms_after_deg, "determined_only_with_orientation": list(self.determined)}
        if self.holdout_rms_after_deg is not None:
            out.update(holdout_rms_before_deg=self.holdout_rms_before_deg,
                       holdout_rms_after_deg=self.holdout_rms_after_deg)
        return out


def determined_text(name: str) -> str:
    """The parameter table's explanation of a parameter the orientations determine."""
    return (f"{name} is determined only with the measured orientation: the measured points alone do "
            f"not tell it apart (the marker sits on or near the axes it turns about).")
