"""Identification's files: the calibrated robot file written (the robot format with its
`calibration` section, docs/file-formats.md), and the run from file paths to that file. The
solver itself takes a RobotModel and Measurements, never paths."""
from __future__ import annotations

from pathlib import Path

from core.identification.result import IdentificationResult
from core.identification.solver import identify
from core.measurement.file import read_measurements
from core.robot.file import read_robot, write_robot


def write_calibrated_model(result: IdentificationResult, path: str | Path) -> Path:
    """Write the calibrated robot file (robot format + `calibration` section) atomically."""
    model = result.model.copy()
    model.calibration = result.calibration_section()
    return write_robot(model, path)


def identify_files(robot_path: str | Path, measurements_path: str | Path, out_path: str | Path | None = None,
                   **options) -> IdentificationResult:
    """File to result: read the robot and the measurements, identify, and (with `out_path`)
    write the calibrated model — only after everything succeeded."""
    robot = read_robot(robot_path)
    meas = read_measurements(measurements_path, robot)
    result = identify(robot, meas, **options)
    if out_path is not None:
        write_calibrated_model(result, out_path)
    return result
