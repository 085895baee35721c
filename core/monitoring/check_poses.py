"""Check poses: a short list of configurations chosen by observability for the parameters that
change most often in a working cell — the target (tool) offsets, the base pose in the camera
frame and the joint zero offsets (θ of revolute joints, d of prismatic ones).

The selection is core.poses.selection.select_poses with every other parameter fixed, so the
observability index is that of the watched set only.
"""
from __future__ import annotations

from typing import Sequence

from core.kinematics.jacobian import Parameter, all_parameters
from core.poses.selection import PoseSelectionResult, select_poses
from core.robot.model import RobotModel

DEFAULT_CHECK_POSES = 8


def joint_zero(p: Parameter, model: RobotModel) -> bool:
    """True for a joint's zero offset (θ of a revolute joint, d of a prismatic one)."""
    return p.group == "joint" and p.kind == ("theta" if model.joints[p.joint].revolute else "d")


def watched_parameters(model: RobotModel, targets: Sequence[str]) -> list[Parameter]:
    """Target offsets, base pose and joint zero offsets, in g's order."""
    return [p for p in all_parameters(model, list(targets))
            if p.group in ("target", "base") or joint_zero(p, model)]


def unwatched_names(model: RobotModel, targets: Sequence[str]) -> list[str]:
    watched = {p.name for p in watched_parameters(model, targets)}
    return [p.name for p in all_parameters(model, list(targets)) if p.name not in watched]


def select_check_poses(model: RobotModel, count: int = DEFAULT_CHECK_POSES, *, target: str = "marker",
                       progress=None, cancelled=None, **options) -> PoseSelectionResult:
    """`count` check poses for the calibrated `model` (its base in the camera frame), chosen
    by observability of the watched parameters; `options` go to select_poses (rig,
    plate_size, visibility, floor, candidates, seed, index …)."""
    options.setdefault("random_trials", 20)
    options.setdefault("curve_max", count)
    return select_poses(model, count, target=target, targets=[target],
                        fixed=unwatched_names(model, [target]), progress=progress, cancelled=cancelled,
                        **options)
