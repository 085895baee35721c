"""A whole calibration over a real serial device: `robocal sim-robot --seed 0` (a subprocess on
a pty, RoboCal protocol and GRBL) serves the virtual lab's true robot; RoboCal connects to the
printed device path as the Setup page does, measures the poses through the SerialRobot with
the lab's cameras rendering the marker at the joints the controller reports, then identifies.
The identified model must predict the true robot better than the nominal one.
(The stereo rig is the lab's true one here; stereo calibration is tested on its own.)"""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from app.hardware import RobotChoice, open_serial_robot
from app.jobs.measurement_hardware import capture_source, measure_hardware
from core.identification.model_comparison import accuracy_against_truth
from core.identification.solver import identify
from core.measurement.file import read_measurements
from core.measurement.run import poses_from_internal
from core.stereo.rectification import load_rectification
from tests.app.virtual_inputs import lab_marker, make_lab, true_stereo_yaml

ROOT = Path(__file__).resolve().parents[2]
N_POSES = 16


@pytest.fixture(scope="module")
def lab():
    return make_lab()                      # seed 0: the robot sim-robot --seed 0 serves


def sim_robot(tmp_path, protocol):
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    proc = subprocess.Popen([sys.executable, "-m", "app.cli", "sim-robot", "--seed", "0", "--protocol", protocol,
                             "--time-scale", "0.01", "--duration", "300"], cwd=tmp_path, env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    port = proc.stdout.readline().strip()
    if not port.startswith("/dev/"):
        proc.kill()
        pytest.fail(f"sim-robot printed no device: {port!r} {proc.stderr.read()}")
    return proc, port


@pytest.mark.parametrize("protocol, profile", [("robocal", "robocal_v1"), ("grbl", "grbl_joint_arm")])
def test_a_whole_calibration_over_sim_robot_beats_nominal(lab, tmp_path, protocol, profile):
    nominal = lab.nominal_robot
    rect = load_rectification(true_stereo_yaml(lab, tmp_path / "stereo.yaml"))
    trained = lab_marker(lab)
    Q = lab.random_visible_poses(N_POSES, np.random.default_rng(21))
    proc, port = sim_robot(tmp_path, protocol)
    try:
        driver = open_serial_robot(nominal, RobotChoice("serial", port, profile), reply_timeout=10.0)
        assert driver.speed == 25.0
        assert "true_geometry" in driver.info.name or protocol == "grbl"
        out = tmp_path / "measurements.csv"
        result = measure_hardware(poses_from_internal(Q, nominal), out, trained, rect, driver,
                                  capture_source(None, lab=lab, driver=driver, seed=0))
        driver.disconnect()
    finally:
        proc.terminate()
        proc.wait(timeout=20)
    assert result.fault is None and len(result.measured) == N_POSES
    meas = read_measurements(out, nominal)
    np.testing.assert_allclose(meas.q_file, nominal.q_to_file(Q), atol=2e-3)   # what the controller reported
    ident = identify(nominal, meas)
    Q_test = lab.random_visible_poses(30, np.random.default_rng(22))
    acc = accuracy_against_truth(lab.true_robot, ident.initial, ident.model, Q_test, [lab.target])
    assert acc.nominal.rms_mm > 1.0 and acc.calibrated.rms_mm < 0.01     # measured: 4.57 mm and 0.003 mm
