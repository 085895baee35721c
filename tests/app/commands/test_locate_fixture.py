"""`robocal locate-fixture` on virtual-lab pairs: the pose file and URDF written, bad inputs as one
line with the usual exit codes."""
from __future__ import annotations

import json

import cv2
import numpy as np
import pytest

from app.cli import main
from core.fixtures.file import read_fixture_pose
from core.fixtures.frame import pose_error


@pytest.fixture(scope="module")
def cell(tmp_path_factory):
    from core.fixtures.description import write_fixture_description
    from core.identification.file import write_calibrated_model
    from core.identification.solver import identify
    from core.virtual_lab.fixture import place_fixture, render_fixture_pairs
    from core.virtual_lab.ideal_measurements import ideal_lab_measurements
    from tests.app.virtual_inputs import make_lab, true_stereo_yaml

    root = tmp_path_factory.mktemp("locate_fixture")
    lab = make_lab()
    fixture = place_fixture(lab)
    true_stereo_yaml(lab, root / "stereo.yaml")
    cv2.imwrite(str(root / "training.png"), lab.render_training_image())
    write_fixture_description(root / "fixture.json", fixture.description())
    write_calibrated_model(identify(lab.nominal_robot, ideal_lab_measurements(lab, 50, sigma_mm=0.05, seed=4)),
                           root / "calibrated.json")
    for side in ("left", "right"):
        (root / "pairs" / side).mkdir(parents=True)
    for name, (left, right) in zip(fixture.names, render_fixture_pairs(lab, fixture, 1)):
        cv2.imwrite(str(root / "pairs" / "left" / f"{name}.png"), left)
        cv2.imwrite(str(root / "pairs" / "right" / f"{name}.png"), right)
    return root, fixture


def _args(root, *rest):
    return ["locate-fixture", "--stereo", str(root / "stereo.yaml"), "--marker", str(root / "training.png"),
            "--marker-size", "40", "--calibrated", str(root / "calibrated.json"),
            "--fixture", str(root / "fixture.json"), *rest]


def test_folder_of_pairs_writes_pose_and_urdf(cell, tmp_path, capsys):
    root, fixture = cell
    out, urdf = tmp_path / "pose.json", tmp_path / "fixture.urdf"
    code = main(_args(root, str(root / "pairs"), "--out", str(out), "--urdf", str(urdf), "--json"))
    captured = capsys.readouterr()
    assert code == 0, captured.err
    data = json.loads(captured.out)
    assert data["format"] == "robocal.fixture/1" and [p["name"] for p in data["points"]] == list("ABCD")
    pose = read_fixture_pose(out)
    e = pose_error(pose.frame.matrix, fixture.pose)
    assert np.all(np.abs(e) <= 3.5 * np.sqrt(np.diag(pose.frame.covariance))), e
    assert pose.sources["calibration"] == str(root / "calibrated.json")
    assert "<joint name=\"fixture_joint\" type=\"fixed\">" in urdf.read_text()


def test_explicit_pairs_in_the_description_order(cell, tmp_path, capsys):
    root, _ = cell
    files = [str(root / "pairs" / side / f"{n}.png") for n in "ABCD" for side in ("left", "right")]
    assert main(_args(root, *files, "--out", str(tmp_path / "pose.json"))) == 0
    assert "Fixture 'virtual fixture' in the robot base frame" in capsys.readouterr().out


def test_bad_inputs_are_one_line(cell, tmp_path, capsys):
    root, _ = cell
    assert main(_args(root, str(root / "pairs" / "left" / "A.png"), "--out", str(tmp_path / "p.json"))) == 2
    assert "1 image files for the 4 fixture points" in capsys.readouterr().err
    assert main(_args(root, str(root / "pairs"), "--out", str(root / "fixture.json"))) == 2
    assert "would overwrite the input" in capsys.readouterr().err
    empty = tmp_path / "empty"
    (empty / "left").mkdir(parents=True)
    assert main(_args(root, str(empty), "--out", str(tmp_path / "p.json"))) == 1
    err = capsys.readouterr().err
    assert "no left image of the fixture point 'A'" in err and len(err.strip().splitlines()) == 1
    assert not (tmp_path / "p.json").exists()


def test_a_robot_file_without_calibration_is_one_line(cell, tmp_path, capsys):
    from core.robot.file import read_robot, write_robot
    from core.robot.model import robot_path

    root, _ = cell
    write_robot(read_robot(robot_path("educational_6r")), tmp_path / "plain.json")
    args = _args(root, str(root / "pairs"), "--out", str(tmp_path / "p.json"))
    args[args.index("--calibrated") + 1] = str(tmp_path / "plain.json")
    assert main(args) == 1
    err = capsys.readouterr().err
    assert "holds no calibration" in err and "plain.json" in err


@pytest.mark.parametrize("change, says", [
    (lambda P: P / 1000.0, "its positions look like metres"),                       # metres written as mm
    (lambda P: P[[1, 0, 2, 3]], "the located points do not match the description"),  # two points swapped
    (lambda P: P * 1.5, "the located points do not match the description"),          # another fixture's size
])
def test_a_description_the_points_do_not_fit_is_refused_with_the_likely_cause(cell, tmp_path, capsys, change, says):
    root, _ = cell
    data = json.loads((root / "fixture.json").read_text())
    P = change(np.array([p["position_mm"] for p in data["points"]], dtype=float))
    for p, xyz in zip(data["points"], P):
        p["position_mm"] = xyz.tolist()
    bad = tmp_path / "fixture.json"
    bad.write_text(json.dumps(data))
    args = _args(root, str(root / "pairs"), "--out", str(tmp_path / "p.json"))
    args[args.index("--fixture") + 1] = str(bad)
    assert main(args) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and says in err[0] and str(bad) in err[0] and "position_mm" in err[0], err
    assert not (tmp_path / "p.json").exists()
