"""A calibrated virtual-lab cell shared by the monitoring tests: the lab (seed 0), its
calibration from 50 ideal measurements (σ 0.05 mm) read back through the robot file, and 8
check poses."""
from __future__ import annotations

import functools
import json
from dataclasses import dataclass

import numpy as np

from core.identification.solver import identify
from core.monitoring.check_poses import select_check_poses
from core.monitoring.uncertainty import CalibrationUncertainty, calibration_uncertainty
from core.robot.file import robot_from_dict, robot_to_dict
from core.robot.model import RobotModel
from core.virtual_lab.ideal_measurements import ideal_lab_measurements
from core.virtual_lab.lab import VirtualLab, lab_options
from tests.session_cache import lab_copy

SIGMA = 0.05


@dataclass
class Cell:
    lab: VirtualLab
    model: RobotModel
    unc: CalibrationUncertainty
    Q: np.ndarray
    options: dict
    true: RobotModel

    def reset(self) -> None:
        self.lab.true_robot = self.true


def calibrate(lab: VirtualLab, seed: int) -> RobotModel:
    res = identify(lab.nominal_robot, ideal_lab_measurements(lab, 50, sigma_mm=SIGMA, seed=seed))
    return robot_from_dict(json.loads(json.dumps(robot_to_dict(res.model))))


@functools.lru_cache(maxsize=1)
def cell() -> Cell:
    lab = lab_copy(seed=0)
    model = calibrate(lab, 4)       # σ̂ 0.049 mm: a typical calibration (seed 1 gives an unlucky 0.043)
    options = lab_options(lab)
    options.pop("robot")
    sel = select_check_poses(model, 8, candidates=500, **options)
    return Cell(lab, model, calibration_uncertainty(model), sel.Q, options, lab.true_robot)
