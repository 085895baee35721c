"""`robocal select-poses`: robot file, virtual lab, stereo.yaml, and one clear line for bad input (no Qt)."""
from __future__ import annotations

import json

import cv2
import numpy as np
import pytest

from app.cli import main
from core.robot.model import robot_path
from core.poses.file import read_poses
from core.robot.file import read_robot, write_robot
from core.stereo.file import StereoFile, write_stereo_yaml
from core.virtual_lab.lab import DEFAULT_BOARD

ROBOT = str(robot_path("educational_6r"))
FAST = ["--candidates", "300", "--random-trials", "20"]


def run(capsys, argv, json_out=True):
    code = main(argv + (["--json"] if json_out else []))
    out, err = capsys.readouterr()
    data = json.loads(out) if (json_out and out.strip()) else None
    return code, data, out, err


def test_select_from_a_robot_file(tmp_path, capsys):
    out = tmp_path / "poses.csv"
    code, data, _, err = run(capsys, ["select-poses", "--robot", ROBOT, "--count", "12", "--out", str(out)] + FAST)
    assert code == 0 and err == ""
    poses = read_poses(out, read_robot(ROBOT))
    assert len(poses) == 12 and data["count"] == 12 and len(data["poses"]) == 12
    np.testing.assert_allclose(poses.q_file, np.array(data["poses"]), atol=5e-4)
    # the selection's indices and, for comparison, the median of random selections
    assert set(data["indices"]) >= {"condition_number", "O1", "O3", "O4", "O5"}
    assert set(data["random_median"]) == {"condition_number", "O1", "O3", "O4", "O5"}
    assert data["indices"]["condition_number"] < data["random_median"]["condition_number"]
    assert data["ratio_to_random"] < 1 and data["random_trials"] == 20
    assert data["min_poses"] == 9 and data["n_parameters"] == 25 and data["depth_mm"] is None
    assert data["travel_after"] <= data["travel_before"] and data["out"] == str(out)


def test_text_output_and_index_choice(tmp_path, capsys):
    out = tmp_path / "p.csv"
    code, _, text, err = run(capsys, ["select-poses", "--robot", ROBOT, "--count", "10", "--out", str(out),
                                      "--index", "O1", "--margin", "10"] + FAST, json_out=False)
    assert code == 0 and err == ""
    assert text.startswith("Selected 10 poses by O1 from 300 candidates")
    assert "random median" in text and f"Wrote {out}." in text


def test_virtual_lab(tmp_path, capsys, built_lab):
    out = tmp_path / "poses.csv"
    code, data, _, err = run(capsys, ["select-poses", "--virtual-lab", "--count", "12", "--out", str(out)] + FAST)
    assert code == 0 and err == ""
    assert len(data["depth_mm"]) == 12 and all(400 <= d <= 900 for d in data["depth_mm"])
    assert data["rejected"]["marker outside an image"] > 0 and data["rejected"]["below the floor"] > 0
    lab = built_lab(seed=0)
    poses = read_poses(out, lab.nominal_robot)
    assert lab.visibility(poses.Q).visible.mean() > 0.7


def _stereo_yaml(lab, path):
    rig = lab.rig
    size = (rig.left.width, rig.left.height)
    R1, R2, P1, P2, Q, *_ = cv2.stereoRectify(rig.left.K, rig.left.dist, rig.right.K, rig.right.dist, size,
                                              rig.R, rig.T.reshape(3, 1))
    data = StereoFile(size, rig.left.K, rig.left.dist, rig.right.K, rig.right.dist, rig.R, rig.T,
                      rig.essential(), rig.fundamental(), R1, R2, P1, P2, Q, 0.1, 0.1, 0.1, DEFAULT_BOARD)
    return write_stereo_yaml(path, data)


def test_stereo_file_with_a_robot_placed_in_the_camera_frame(tmp_path, capsys, built_lab):
    lab = built_lab(seed=0)
    stereo = _stereo_yaml(lab, tmp_path / "stereo.yaml")
    placed = write_robot(lab.nominal_robot, tmp_path / "robot.json")
    out = tmp_path / "poses.csv"
    code, data, _, err = run(capsys, ["select-poses", "--robot", str(placed), "--stereo", str(stereo), "--count", "12",
                                      "--out", str(out), "--plate", "60"] + FAST)
    assert code == 0 and err == ""
    assert all(350 <= d <= 1000 for d in data["depth_mm"])
    # the preset's base is not in the camera frame: nothing is in view, and the message says what to check
    code, _, _, err = run(capsys, ["select-poses", "--robot", ROBOT, "--stereo", str(stereo), "--count", "12",
                                   "--out", str(tmp_path / "x.csv"), "--candidates", "50"])
    assert code == 1 and err.count("\n") == 1
    assert "no candidate pose puts the marker in view of both cameras" in err
    assert "check the robot base pose in robot.json" in err.lower() and "margins" in err
    assert not (tmp_path / "x.csv").exists()


@pytest.mark.parametrize("content", [None, "{not json", '{"format": "robocal.robot/1", "joints": []}'])
def test_unreadable_robot_file(tmp_path, capsys, content):
    robot = tmp_path / "robot.json"
    if content is not None:
        robot.write_text(content)
    code, _, out, err = run(capsys, ["select-poses", "--robot", str(robot), "--count", "12",
                                     "--out", str(tmp_path / "p.csv")])
    assert code == 1 and out == "" and err.count("\n") == 1 and "Traceback" not in err
    assert err.startswith("robocal select-poses: ") and str(robot) in err
    assert not (tmp_path / "p.csv").exists()


def test_usage_errors(tmp_path, capsys):
    out = str(tmp_path / "p.csv")
    code, _, _, err = run(capsys, ["select-poses", "--robot", ROBOT, "--count", "5", "--out", out] + FAST)
    assert code == 2 and err.count("\n") == 1 and "at least 9 poses" in err
    code, _, _, err = run(capsys, ["select-poses", "--robot", ROBOT, "--count", "30", "--out", out,
                                   "--candidates", "20"])
    assert code == 2 and "--candidates (20) must be at least --count (30)" in err
    code, _, _, err = run(capsys, ["select-poses", "--count", "12", "--out", out])
    assert code == 2 and "--robot is required" in err
    code, _, _, err = run(capsys, ["select-poses", "--robot", ROBOT, "--count", "12", "--out", out,
                                   "--index", "O2"])
    assert code == 2 and "invalid choice" in err
    code, _, _, err = run(capsys, ["select-poses", "--robot", ROBOT, "--count", "12", "--out", out,
                                   "--margin", "100"] + FAST)
    assert code == 1 and "leaves no range for joint 2" in err
