"""The true offset of a lab target as a calibrated arm sees it, the truth a tool identification
is judged against."""
from __future__ import annotations

import numpy as np

from core.robot.model import RobotModel


def equivalent_offset(lab, model: RobotModel, target: str, n: int = 300, seed: int = 99) -> np.ndarray:
    """The least-squares offset (mm, `model`'s tool frame) that puts the calibrated `model`'s tool
    frame on the lab's true `target` at `n` random visible poses. It differs from the lab's raw
    true offset by what a target identified on that arm absorbs of the last joint's errors (e.g.
    its d along the tool axis): the calibration's own marker absorbs them the same way."""
    Q = lab.random_visible_poses(n, np.random.default_rng(seed))
    T = model.fk_many(Q)
    truth = lab.true_robot.target_positions(Q, target)
    return np.einsum("nji,nj->ni", T[:, :3, :3], truth - T[:, :3, 3]).mean(axis=0)
