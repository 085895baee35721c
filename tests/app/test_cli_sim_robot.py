"""`robocal sim-robot`: serves the virtual lab's true robot on a pty (a real subprocess)."""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np

from app.cli import main
from core.robot.file import read_robot
from core.robot.model import robot_path
from core.robot.serial_robot import SerialRobot

ROOT = Path(__file__).resolve().parents[2]


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
