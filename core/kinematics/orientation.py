"""The marker frame a robot model predicts, and its Jacobian rows.

The model predicts the marker frame in the measurement frame as R = R_tool(q) · R_target, with
R_target = `RobotModel.target_rotations[target]` (identity when absent) the marker's orientation
on the tool, estimated as the parameters `<target>.rx/.ry/.rz` (core.kinematics.jacobian).
A parameter change turns the predicted frame by a small rotation ω (measurement frame), with
(frames as in core.kinematics.jacobian)
    ∂ω/∂θ_i = z_(i-1)      ∂ω/∂α_i = x'_i      ∂ω/∂β_i = y_i      ∂ω/∂d_i = ∂ω/∂a_i = 0
    ∂ω/∂base.r(x,y,z) = e_(x,y,z)    ∂ω/∂base.(x,y,z) = ∂ω/∂target.(x,y,z) = 0
    ∂ω/∂target.r(x,y,z) = the tool frame's x, y, z axis.
The residuals against measured frames are in core.identification.orientation.
"""
from __future__ import annotations

from typing import Sequence

import numpy as np

from core.kinematics.jacobian import Parameter
from core.robot.model import RobotModel

# Orientation rows in the structural analysis (no measured sigmas there): 1 mrad counts as 1 mm.
STRUCTURAL_ROW_SCALE = 1000.0


def target_rotation(model: RobotModel, target: str) -> np.ndarray:
    return np.asarray(model.target_rotations.get(target, np.eye(3)), dtype=float)


def predict_rotations(model: RobotModel, Q, point_targets: Sequence[str]) -> np.ndarray:
    """(N, 3, 3) predicted marker frames in the measurement frame."""
    T = model.fk_many(np.atleast_2d(np.asarray(Q, dtype=float)))
    R_t = np.array([target_rotation(model, t) for t in point_targets]).reshape(-1, 3, 3)
    return T[:, :3, :3] @ R_t


def has_orientation_parameters(params: Sequence[Parameter]) -> bool:
    return any(p.group == "orientation" for p in params)


def orientation_jacobian(model: RobotModel, Q, point_targets: Sequence[str],
                         params: Sequence[Parameter]) -> np.ndarray:
    """(3N, p) ∂ω/∂(correction of each parameter), rows stacked point by point."""
    Q = np.atleast_2d(np.asarray(Q, dtype=float))
    N, n = Q.shape
    F = model.frames_many(Q)
    tool_R = F[:, n + 1, :3, :3]
    beta = np.array([j.beta for j in model.joints])
    out = np.zeros((N, 3, len(params)))
    eye = np.eye(3)
    for k, prm in enumerate(params):
        if prm.group == "joint":
            i = prm.joint
            if prm.kind == "theta":
                col = F[:, i, :3, 2]
            elif prm.kind == "alpha":
                col = F[:, i + 1, :3, :3] @ np.array([np.cos(beta[i]), 0.0, np.sin(beta[i])])
            elif prm.kind == "beta":
                col = F[:, i + 1, :3, 1]
            else:
                continue
        elif prm.group == "base":
            if len(prm.kind) == 1:
                continue
            col = np.broadcast_to(eye["xyz".index(prm.kind[1])], (N, 3))
        elif prm.group == "orientation":
            col = tool_R[:, :, "xyz".index(prm.kind[1])] * np.array(
                [t == prm.target for t in point_targets], dtype=float)[:, None]
        else:
            continue
        out[:, :, k] = col
    return out.reshape(3 * N, len(params))
