"""A small project with every step's output, made quickly without the wizard: the educational
6R arm, a stereo.yaml (and its stereo.json details), 30 poses with synthetic measurements of a
perturbed robot, and calibrated.json identified with a quarter of the poses held out."""
from __future__ import annotations

import cv2
import numpy as np

from core.files import atomic_write_json
from core.identification.file import write_calibrated_model
from core.identification.solver import identify
from core.measurement.file import write_measurements
from core.poses.file import write_poses
from core.project import create_project, save_robot
from core.robot.file import read_robot
from core.robot.model import robot_path
from core.stereo.board import Board
from core.stereo.file import StereoFile, write_stereo_yaml
from core.virtual_lab.synthetic import perturbed_model, simulate_measurements

THRESHOLD_PX = 0.5


def stereo_file() -> StereoFile:
    K = np.array([[800.0, 0, 320], [0, 800, 256], [0, 0, 1]])
    D = np.zeros(5)
    R, T = np.eye(3), np.array([-120.0, 0.0, 0.0])
    R1, R2, P1, P2, Q, *_ = cv2.stereoRectify(K, D.reshape(1, 5), K, D.reshape(1, 5), (640, 512), R,
                                             T.reshape(3, 1))
    E = np.array([[0, 0, 0], [0, 0, 120.0], [0, -120.0, 0]])
    F = np.linalg.inv(K).T @ E @ np.linalg.inv(K)
    return StereoFile((640, 512), K, D, K, D, R, T, E, F, R1, R2, P1, P2, Q, 0.21, 0.23, 0.31,
                      Board(9, 6, 25.0), {"epipolar_rms": 0.05})


def stereo_details(pairs: int = 8) -> dict:
    rng = np.random.default_rng(1)
    views = [{"pair": i + 1, "files": f"pair{i + 1}", "rms_left": 0.2 + 0.01 * i, "rms_right": 0.25,
              "rms": 0.23, "outlier": i == pairs - 1,
              "residuals_left_px": rng.normal(0, 0.2, (54, 2)).tolist(),
              "residuals_right_px": rng.normal(0, 0.2, (54, 2)).tolist()} for i in range(pairs)]
    views[-1]["rms_left"] = 0.9
    return {"format": "robocal.stereo/1", "outlier_threshold_px": THRESHOLD_PX, "views": views,
            "parameters": [{"group": "left", "name": "fx", "value": 800.1, "std": 0.4, "unit": "px",
                            "fixed": False}],
            "calibration": {"coverage": COVERAGE, "cross_validation": CROSS_VALIDATION}}


COVERAGE = {"X": 0.66, "Y": 1.0, "size": 0.45, "skew": 0.8, "pairs": 8, "enough": False,
            "advice": ["show the board nearer and farther"]}
CROSS_VALIDATION = {"rms_px": 0.14, "max_px": 1.3, "rms_observed_px": 0.012, "left_rms_px": 0.16,
                    "right_rms_px": 0.11, "baseline_diff_mm": 0.008, "rotation_diff_deg": 0.0096,
                    "split": "interleaved (even / odd pairs)"}


def make_project(folder):
    """The project (every file written) and the identification result."""
    project = create_project(folder, name="sample")
    robot = read_robot(robot_path("educational_6r"))
    save_robot(project, robot, "preset:educational_6r")
    write_stereo_yaml(project.path("stereo"), stereo_file())
    atomic_write_json(project.path("stereo_details"), stereo_details())
    meas = simulate_measurements(perturbed_model(robot, 4), 30, sigma_mm=0.05, rng=5)
    write_poses(project.path("poses"), meas.q_file)
    write_measurements(meas, project.path("measurements"))
    result = identify(robot, meas, holdout=0.25)
    write_calibrated_model(result, project.path("calibrated"))
    return project, result
