"""The Pose sequence step's work: select poses, in the virtual lab when one is given."""
from __future__ import annotations

from app.lab import VirtualLab, lab_options
from core.poses.selection import PoseSelectionResult, select_poses
from core.robot.model import RobotModel


def run_pose_selection(robot: RobotModel, count: int, *, lab: VirtualLab | None = None, index: str = "cond",
                       candidates: int = 1000, margin: float = 5.0, seed: int = 0,
                       progress=None, cancelled=None) -> PoseSelectionResult:
    """Select `count` poses for `robot` by `index`, `margin` in degrees (mm for prismatic joints).

    With a `lab`, the candidates are those of its placed nominal robot (base in the left camera
    frame) that both of its cameras see, above its table; without one, any feasible pose of `robot`.
    """
    options = lab_options(lab) if lab is not None else {"robot": robot}
    model = options.pop("robot")
    return select_poses(model, count, candidates=candidates, index=index, seed=seed, margin=margin,
                        progress=progress, cancelled=cancelled, **options)
