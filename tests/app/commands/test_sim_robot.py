"""`robocal sim-robot`: serves the virtual lab's true robot on a pty (a real subprocess)."""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import cv2
import numpy as np

from app.cli import main
from core.robot.file import read_robot
from core.robot.model import robot_path
from core.robot.serial_robot import SerialRobot

ROOT = Path(__file__).resolve().parents[3]


def test_bad_fault_spec_is_a_usage_error(capsys):
    assert main(["sim-robot", "--faults", "melt@2"]) == 2
    assert "fault 'melt@2' is not KIND@MOVE" in capsys.readouterr().err


def test_sim_robot_serves_the_lab_robot_on_a_pty(tmp_path):
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    proc = subprocess.Popen([sys.executable, "-m", "app.cli", "sim-robot", "--seed", "3", "--time-scale", "0.01",
                             "--duration", "60", "--protocol", "robocal"], cwd=tmp_path, env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        port = proc.stdout.readline().strip()
        assert port.startswith("/dev/pts/"), proc.stderr.read() if not port else port
        model = read_robot(robot_path("educational_6r"))
        driver = SerialRobot(model, port, reply_timeout=10.0, move_timeout=30.0)
        driver.connect()
        assert driver.info.name == "Educational_6R_arm_(Robix_RCS-6_style)_(virtual_lab,_true_geometry)"
        q = model.q_from_file([5, 10, -15, 20, 25, 30])
        driver.move_to(q)
        np.testing.assert_allclose(driver.current_joints(), q, atol=1e-5)
        driver.disconnect()
    finally:
        proc.terminate()
        proc.wait(timeout=20)


def test_a_change_needs_the_cameras_that_see_it(capsys):
    assert main(["sim-robot", "--change", "tool:1.5"]) == 2
    assert "--change alters what the cameras see" in capsys.readouterr().err


def test_the_cameras_see_the_changed_robot(tmp_path):
    """`--cameras DIR --change tool:1.5`: after a move the two folders hold the pair the lab's
    cameras see; the marker located in it is 1.5 mm from where the unchanged robot puts it."""
    from core.marker.location import MarkerLocator
    from core.stereo.rectification import load_rectification
    from tests.app.virtual_inputs import lab_marker, make_lab, true_stereo_yaml

    lab = make_lab()
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    cams = tmp_path / "cams"
    proc = subprocess.Popen([sys.executable, "-m", "app.cli", "sim-robot", "--seed", "0", "--time-scale", "0.01",
                             "--duration", "120", "--cameras", str(cams), "--change", "tool:1.5"], cwd=tmp_path,
                            env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        port = proc.stdout.readline().strip()
        assert port.startswith("/dev/pts/"), proc.stderr.read() if not port else port
        driver = SerialRobot(lab.nominal_robot, port, reply_timeout=10.0, move_timeout=30.0)
        driver.connect()
        q = lab.random_visible_poses(1, np.random.default_rng(8))[0]
        driver.move_to(q)
        driver.disconnect()
        left, right = (cv2.imread(str(cams / side / "frame.png"), cv2.IMREAD_UNCHANGED) for side in ("left", "right"))
    finally:
        proc.terminate()
        proc.wait(timeout=20)
    locator = MarkerLocator(lab_marker(lab), load_rectification(true_stereo_yaml(lab, tmp_path / "stereo.yaml")))
    found = locator.locate(left, right)
    assert found.ok
    unchanged = lab.true_robot.target_position(q, lab.target)
    assert abs(np.linalg.norm(found.point - unchanged) - 1.5) < 0.1
