"""A virtual-lab cell with a tool changer, shared by the tool tests: the educational 6R arm with
two tools ("gripper" carrying "marker", "long_gripper" carrying "long_marker" 110 mm out), the
lab (seed 0) built from it, and its calibration with the gripper from 50 ideal measurements
(σ 0.05 mm), read back through the robot file."""
from __future__ import annotations

import functools
import json

import numpy as np

from core.identification.solver import identify
from core.robot.file import read_robot, robot_from_dict, robot_to_dict
from core.robot.model import RobotModel, robot_path
from core.virtual_lab.ideal_measurements import ideal_lab_measurements
from core.virtual_lab.lab import VirtualLab

SIGMA = 0.05
LONG = np.array([0.0, 15.0, 110.0])


def two_tool_robot() -> RobotModel:
    robot = read_robot(robot_path("educational_6r"))
    robot.targets["long_marker"] = LONG.copy()
    robot.tools = {"gripper": ["marker"], "long_gripper": ["long_marker"]}
    return robot


@functools.lru_cache(maxsize=1)
def calibrated_cell() -> tuple[VirtualLab, RobotModel]:
    """(lab with the gripper mounted, calibrated robot); tests must not change them."""
    lab = VirtualLab.create(two_tool_robot(), seed=0)
    result = identify(lab.nominal_robot, ideal_lab_measurements(lab, 50, sigma_mm=SIGMA, seed=4))
    return lab, robot_from_dict(json.loads(json.dumps(robot_to_dict(result.model))))


def equivalent_offset(lab: VirtualLab, model: RobotModel, target: str, n: int = 300) -> np.ndarray:
    """The true offset of `target` as the calibrated arm sees it (mm, tool frame): the least-squares
    offset that puts `model`'s tool frame on the lab's true target at many random visible poses.
    It differs from the lab's raw true offset by what the calibrated target absorbed of the last
    joint's errors (e.g. its d along the tool axis), as every target measured on that arm does."""
    Q = lab.random_visible_poses(n, np.random.default_rng(99))
    T = model.fk_many(Q)
    truth = lab.true_robot.target_positions(Q, target)
    return np.einsum("nji,nj->ni", T[:, :3, :3], truth - T[:, :3, 3]).mean(axis=0)
