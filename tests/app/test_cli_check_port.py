"""`robocal check --port --cameras`: an unattended check of a connected cell. The robot is `robocal
sim-robot` on a real pseudo-terminal (seed 0: the virtual lab's true robot); the cameras are two
image folders holding the pairs the lab renders at the check poses (read with the camera code
the Setup page uses). A robot fault stops the check with what was measured in the log, exit 1."""
from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import cv2
import numpy as np
import pytest

from app.cli import main
from app.lab import ideal_lab_measurements
from core.identification.solver import identify, write_calibrated_model
from core.monitoring.log import read_check_log
from core.poses.file import read_poses
from core.virtual_lab.changes import apply_change
from tests.app.virtual_inputs import true_stereo_yaml

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def cell(tmp_path_factory, built_lab):
    """(folder, lab, calibrated.json, stereo.yaml, training.png, check poses file)."""
    root = tmp_path_factory.mktemp("checkport")
    lab = built_lab(None, 0, 0.5)
    write_calibrated_model(identify(lab.nominal_robot, ideal_lab_measurements(lab, 50, sigma_mm=0.05, seed=4)),
                           root / "calibrated.json")
    true_stereo_yaml(lab, root / "stereo.yaml")
    cv2.imwrite(str(root / "training.png"), lab.render_training_image())
    assert main(["check", "--robot", str(root / "calibrated.json"), "--propose-poses", str(root / "poses.csv"),
                 "--stereo", str(root / "stereo.yaml")]) == 0
    return root, lab


def cameras(lab, root, folder, change=None):
    Q = read_poses(root / "poses.csv", lab.nominal_robot).Q
    true = lab.true_robot
    if change:
        apply_change(lab, change, seed=0)
    rng = np.random.default_rng(5)
    try:
        for side in ("left", "right"):
            (folder / side).mkdir(parents=True)
        for k, q in enumerate(Q):
            left, right = lab.render_marker_pair(q, rng)
            cv2.imwrite(str(folder / "left" / f"{k:03d}.png"), left)
            cv2.imwrite(str(folder / "right" / f"{k:03d}.png"), right)
    finally:
        lab.true_robot = true
    return f"{folder / 'left'},{folder / 'right'}"


def sim_robot(tmp_path, faults=""):
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    proc = subprocess.Popen([sys.executable, "-m", "app.cli", "sim-robot", "--seed", "0", "--time-scale", "0.01",
                             "--duration", "300"] + (["--faults", faults] if faults else []), cwd=tmp_path, env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    port = proc.stdout.readline().strip()
    if not port.startswith("/dev/"):
        proc.kill()
        pytest.fail(f"sim-robot printed no device: {port!r} {proc.stderr.read()}")
    return proc, port


def check(root, port, cams, log, capsys, extra=()):
    code = main(["check", "--robot", str(root / "calibrated.json"), "--log", str(log), "--port", port,
                 "--profile", "robocal_v1", "--cameras", cams, "--stereo", str(root / "stereo.yaml"),
                 "--marker", str(root / "training.png"), "--poses", str(root / "poses.csv"), "--json", *extra])
    out, err = capsys.readouterr()
    return code, (json.loads(out) if out.strip() else None), err


@pytest.mark.parametrize("change, code, kind", [(None, 0, "none"), ("tool:1.5", 3, "tool")])
def test_a_check_drives_the_serial_robot_and_says_so(cell, tmp_path, capsys, change, code, kind):
    root, lab = cell
    cams = cameras(lab, root, tmp_path / "cams", change)
    proc, port = sim_robot(tmp_path)
    try:
        got, data, err = check(root, port, cams, tmp_path / "c.csv", capsys,
                               ["--reid-poses", str(tmp_path / "reid.csv")])
    finally:
        proc.terminate()
        out, _ = proc.communicate(timeout=20)
    assert got == code, err
    assert data["change"] == kind and data["measured_on"].startswith(f"serial robot on {port} (RoboCal serial protocol v1), cameras ")
    assert len(data["poses"]) == 8
    assert (tmp_path / "reid.csv").exists() == (kind == "tool")
    logged = read_check_log(tmp_path / "c.csv").checks
    assert len(logged) == 1 and logged[0].finished and len(logged[0].points) == 8
    np.testing.assert_allclose([p.q_file for p in logged[0].points],
                               read_poses(root / "poses.csv").q_file, atol=2e-3)      # as the controller reported


def test_a_robot_fault_stops_the_check_with_the_log_kept(cell, tmp_path, capsys):
    root, lab = cell
    cams = cameras(lab, root, tmp_path / "cams")
    proc, port = sim_robot(tmp_path, "fault@4")
    try:
        code, data, err = check(root, port, cams, tmp_path / "c.csv", capsys)
    finally:
        proc.terminate()
        proc.communicate(timeout=20)
    assert code == 1 and data is None and "FAULT" in err and len(err.strip().splitlines()) == 1
    logged = read_check_log(tmp_path / "c.csv").checks
    assert len(logged) == 1 and not logged[0].finished and 1 <= len(logged[0].points) < 8
