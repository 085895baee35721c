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
from tests.session_cache import lab_copy

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
    lab = lab_copy(two_tool_robot(), seed=0)
    result = identify(lab.nominal_robot, ideal_lab_measurements(lab, 50, sigma_mm=SIGMA, seed=4))
    return lab, robot_from_dict(json.loads(json.dumps(robot_to_dict(result.model))))

