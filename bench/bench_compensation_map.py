"""Accuracy map over `robocal sim-robot`: 20 targets reached with the nominal and the calibrated model."""
from __future__ import annotations

import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from app.jobs.compensation import load_cell, measure_accuracy_map, robot_measure
from core.identification.file import write_calibrated_model
from core.identification.solver import identify
from core.marker.training import train_marker
from core.measurement.capture import RenderedSource
from core.robot.serial_robot import SerialRobot
from core.stereo.rectification import StereoRectification
from core.virtual_lab.ideal_measurements import ideal_lab_measurements, write_ideal_measurements
from core.virtual_lab.lab import VirtualLab

ROOT = Path(__file__).resolve().parents[1]
SEED = 0
TARGETS = 20
CALIBRATION_POSES = 50
CALIBRATION_SIGMA_MM = 0.05


def _sim_robot() -> tuple[subprocess.Popen, str]:
    """`robocal sim-robot` (the virtual lab's true robot, seed SEED) as a subprocess; its pty."""
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    proc = subprocess.Popen([sys.executable, "-m", "app.cli", "sim-robot", "--seed", str(SEED), "--time-scale",
                             "0.05", "--duration", "900"], env=env, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    port = proc.stdout.readline().strip()
    if not port.startswith("/dev/"):
        proc.terminate()
        raise RuntimeError(f"robocal sim-robot did not start: {proc.stderr.read()}")
    return proc, port


def run(report) -> None:
    lab = VirtualLab.create(seed=SEED, noise=0.5)          # the lab `robocal sim-robot --seed 0` serves
    with tempfile.TemporaryDirectory(prefix="robocal-bench-") as tmp:
        tmp = Path(tmp)
        meas = ideal_lab_measurements(lab, CALIBRATION_POSES, sigma_mm=CALIBRATION_SIGMA_MM, seed=4)
        write_ideal_measurements(meas, tmp / "measurements.csv", sigma_mm=CALIBRATION_SIGMA_MM)
        write_calibrated_model(identify(lab.nominal_robot, meas), tmp / "calibrated.json")
        report.info(f"calibration poses (virtual lab, {CALIBRATION_SIGMA_MM} mm noise per axis)", CALIBRATION_POSES,
                    "poses")
        cell = load_cell(tmp / "calibrated.json", lab.nominal_robot, tmp / "measurements.csv")
        images = (train_marker(lab.render_training_image(), outer_size=lab.marker.outer_size),
                  StereoRectification.from_rig(lab.rig))
        proc, port = _sim_robot()
        try:
            driver = SerialRobot(lab.nominal_robot, port, speed=100, reply_timeout=10.0, move_timeout=60.0)
            driver.connect()
            rng = np.random.default_rng(1)
            source = RenderedSource(lambda: lab.render_marker_pair(driver.current_joints(), rng))
            measure, where = robot_measure(driver, source, images, rendered=True)
            t = time.perf_counter()
            run_ = measure_accuracy_map(cell, tmp / "measurements.csv", measure, where, tmp, count=TARGETS,
                                        keep=lambda Q: lab.visibility(Q).visible)
            seconds = time.perf_counter() - t
            driver.disconnect()
        finally:
            proc.terminate()
            proc.wait(timeout=30)
    amap = run_.amap
    report.info(f"targets measured both ways over sim-robot ({port})", int(amap.both.sum()), f"of {amap.n}")
    report.info("accuracy map time (2 moves, renders and locations per target)", seconds, "s")
    report.add("accuracy map over sim-robot: targets measured both ways", int(amap.both.sum()), ">=", 18, "")
    report.info("nominal model: RMS error measured by the cameras", amap.rms_before_mm, "mm")
    report.info("nominal model: max error", amap.max_before_mm, "mm")
    report.info("calibrated model: RMS error measured by the cameras", amap.rms_after_mm, "mm")
    report.info("calibrated model: max error", amap.max_after_mm, "mm")
    report.add("accuracy map over sim-robot: RMS before / RMS after", amap.improvement, ">=", 20.0, "×")
