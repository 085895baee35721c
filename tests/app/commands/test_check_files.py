"""`robocal check` and `robocal reidentify` on files, as a cell outside RoboCal gives them: the
calibration made by the README's chain (`simulate` → `measure` → `identify`, a weighted
calibration), check poses proposed with the stereo calibration, their pairs rendered by the
virtual lab and written as PNG files, read back through `--joints --images`; points from a
measurements file; the re-identification from the proposed poses' pairs."""
from __future__ import annotations

import json
from pathlib import Path

import cv2
import numpy as np
import pytest

from app.cli import main
from core.monitoring.log import read_check_log
from core.poses.file import read_poses
from core.robot.file import read_robot
from core.robot.model import robot_path
from core.virtual_lab.changes import apply_change
from tests.app.commands.cli_output import run_json
from tests.app.virtual_inputs import marker_dataset

SEED = 3


@pytest.fixture(scope="module")
def cell(tmp_path_factory, built_lab):
    """(folder, dataset, calibrated.json, lab): the README chain on a 36-pose dataset of lab seed 3
    (the module's lab: a copy of the session's)."""
    root = tmp_path_factory.mktemp("checkfiles")
    ds = marker_dataset(root, poses=36, seed=SEED)
    assert main(["measure", "--stereo", str(ds / "stereo.yaml"), "--marker", str(ds / "marker" / "training.png"),
                 "--images", str(ds / "poses"), "--joints", str(ds / "poses" / "joints.csv"),
                 "--out", str(root / "meas.csv")]) == 0
    assert main(["identify", "--robot", str(robot_path("educational_6r")), "--measurements", str(root / "meas.csv"),
                 "--out", str(root / "calibrated.json"), "--holdout", "0.25"]) == 0
    return root, ds, root / "calibrated.json", built_lab(None, SEED, 0.5)


def locator_args(ds):
    return ["--stereo", str(ds / "stereo.yaml"), "--marker", str(ds / "marker" / "training.png")]


def capture(lab, poses_csv, folder, change=None, seed=0):
    """Render the lab's pairs at the joints file's poses (after `change` to its true robot) into
    folder/left, folder/right as PNG files, as two cameras would have captured them."""
    model = read_robot(robot_path("educational_6r"))
    Q = read_poses(poses_csv, model).Q
    true = lab.true_robot
    if change:
        apply_change(lab, change, seed=0)
    rng = np.random.default_rng(seed)
    try:
        for side in ("left", "right"):
            (folder / side).mkdir(parents=True, exist_ok=True)
        for k, q in enumerate(Q):
            left, right = lab.render_marker_pair(q, rng)
            assert cv2.imwrite(str(folder / "left" / f"{k:03d}.png"), left)
            assert cv2.imwrite(str(folder / "right" / f"{k:03d}.png"), right)
    finally:
        lab.true_robot = true
    return folder


@pytest.mark.slow
def test_the_readme_chain_writes_a_weighted_calibration_that_can_be_checked(cell, tmp_path, capsys):
    root, ds, calibrated, lab = cell
    stats = read_robot(calibrated).calibration["statistics"]
    assert stats["sigma_hat_unit"] != "mm"                      # weighted by the points' own σ
    poses = tmp_path / "check_poses.csv"
    code, data, err = run_json(capsys, ["check", "--robot", str(calibrated), "--propose-poses", str(poses),
                                        "--stereo", str(ds / "stereo.yaml")])
    assert code == 0, err
    assert data["poses"] == 8 and len(read_poses(poses).pose) == 8
    images = capture(lab, poses, tmp_path / "pairs")
    code, data, err = run_json(capsys, ["check", "--robot", str(calibrated), "--log", str(tmp_path / "c.csv"),
                                        "--joints", str(poses), "--images", str(images)] + locator_args(ds))
    assert code == 0, err
    assert data["in_limits"] and data["change"] == "none"
    assert data["measured_on"] == f"image files in {images}"
    assert len(data["poses"]) == 8 and all(p["error_mm"] <= p["limit_mm"] for p in data["poses"])
    # the limits come from the calibration's own error (a few µm on the lab: measured 0.0028 mm),
    # not from a σ̂ factor (about 1) nor from another unit
    assert 0.001 < data["check"]["sigma_mm"] < 0.05
    assert len(read_check_log(tmp_path / "c.csv").checks[0].points) == 8


@pytest.mark.slow
def test_a_tool_change_is_found_in_captured_pairs_and_reidentified_from_the_proposed_poses(cell, tmp_path, capsys):
    root, ds, calibrated, lab = cell
    poses, log, reid = tmp_path / "check_poses.csv", tmp_path / "c.csv", tmp_path / "reid.csv"
    assert main(["check", "--robot", str(calibrated), "--propose-poses", str(poses),
                 "--stereo", str(ds / "stereo.yaml")]) == 0
    capsys.readouterr()
    images = capture(lab, poses, tmp_path / "pairs", change="tool:1.5")
    code, data, err = run_json(capsys, ["check", "--robot", str(calibrated), "--log", str(log), "--joints", str(poses),
                                        "--images", str(images), "--reid-poses", str(reid)] + locator_args(ds))
    assert code == 3, err
    assert not data["in_limits"] and data["change"] == "tool"
    assert data["rms_mm"] > 1.0 and data["reid_poses"]["poses"] >= 1
    # each point located in a pair is logged with its own covariance, for the re-identification's check
    assert all(p.covariance is not None and p.covariance[2, 2] > 0 for p in read_check_log(log).checks[0].points)
    new = capture(lab, reid, tmp_path / "reid_pairs", change="tool:1.5", seed=1)
    out = tmp_path / "updated.json"
    code, data, err = run_json(capsys, ["reidentify", "--robot", str(calibrated), "--log", str(log), "--change", "tool",
                                        "--joints", str(reid), "--images", str(new), "--out", str(out)]
                               + locator_args(ds))
    assert code == 0, err
    assert data["in_limits"] and data["out"] == str(out)
    change = data["reidentification"]["change"]
    assert np.linalg.norm([change[f"marker.{a}"] for a in "xyz"]) == pytest.approx(1.5, abs=0.02)
    history = read_robot(out).calibration["history"]
    assert history[-1]["changed"] == ["marker.x", "marker.y", "marker.z"] and history[-1]["updated"] == "calibrated.json"
    assert len(read_check_log(log).checks) == 2                 # the check, and that of the updated robot
    # the updated robot checked on new pairs at the check poses: within limits again
    again = capture(lab, poses, tmp_path / "again", change="tool:1.5", seed=2)
    code, data, err = run_json(capsys, ["check", "--robot", str(out), "--log", str(log), "--joints", str(poses),
                                        "--images", str(again)] + locator_args(ds))
    assert code == 0 and data["in_limits"], err


def test_a_measurements_file_is_checked(cell, tmp_path, capsys):
    root, ds, calibrated, lab = cell
    code, data, err = run_json(capsys, ["check", "--robot", str(calibrated), "--log", str(tmp_path / "c.csv"),
                                        "--measurements", str(root / "meas.csv")])
    assert code in (0, 3), err
    assert data["measured_on"] == f"measurement file {root / 'meas.csv'}" and len(data["poses"]) == 36
    # the calibration's own points: within limits but for the rare false alarm of 36 points
    assert sum(not p["within"] for p in data["poses"]) <= 1


@pytest.mark.parametrize("argv, message", [
    ([], "say where to measure"),
    (["--joints", "j.csv"], "--joints, --images, --stereo and --marker together"),
    (["--measurements", "m.csv", "--lab"], "one place to measure"),
    (["--measurements", "m.csv", "--out", "u.json"], "robocal reidentify"),
    (["--port", "/dev/null"], "--port, --cameras, --stereo and --marker together"),
    (["--port", "/dev/null", "--cameras", "0"], "expected two cameras LEFT,RIGHT"),
    (["--measurements", "m.csv", "--cell-clear"], "--cell-clear is for the connected cell (--port)")])
def test_usage_errors(cell, tmp_path, capsys, argv, message):
    root, ds, calibrated, lab = cell
    code = main(["check", "--robot", str(calibrated), "--log", str(tmp_path / "c.csv")] + argv)
    assert code == 2 and message in capsys.readouterr().err


IRB = Path(__file__).resolve().parents[4] / "shared" / "data" / "irb120-laser-tracker"


@pytest.mark.skipif(not IRB.is_dir(), reason=f"IRB 120 laser-tracker data not found at {IRB}")
def test_a_laser_tracker_calibration_checks_its_own_points(tmp_path, capsys):
    """The real IRB 120 tracker data imported, identified, and checked on its reflector p1's
    points: the limits come from the calibration's σ̂ in mm (0.15 mm)."""
    robot = str(robot_path("abb_irb120"))
    meas, calibrated = tmp_path / "tracker.csv", tmp_path / "calibrated.json"
    assert main(["import-measurements", str(IRB / "calibration.csv"), str(IRB / "test_points_at_zero.csv"),
                 "--robot", robot, "--out", str(meas)]) == 0
    assert main(["identify", "--robot", robot, "--measurements", str(meas), "--out", str(calibrated)]) == 0
    capsys.readouterr()
    code, data, err = run_json(capsys, ["check", "--robot", str(calibrated), "--log", str(tmp_path / "c.csv"),
                                        "--measurements", str(meas)])
    assert code == 0 and data["in_limits"], err
    assert len(data["poses"]) == 36 and 0.1 < data["check"]["sigma_mm"] < 0.2
    assert data["measured_on"] == f"measurement file {meas}"
    code = main(["check", "--robot", str(calibrated), "--log", str(tmp_path / "c.csv"), "--measurements",
                 str(meas), "--tool", "no_such_tool"])
    assert code == 1 and len(capsys.readouterr().err.strip().splitlines()) == 1


def test_a_calibration_with_a_useless_noise_is_one_line(cell, tmp_path, capsys):
    """A σ̂ of 1e308 mm (a calibration that did not converge) is refused naming the field."""
    root, ds, calibrated, lab = cell
    data = json.loads(calibrated.read_text())
    data["calibration"]["statistics"].update(sigma_hat=1e308, sigma_hat_unit="mm")
    data["calibration"]["statistics"].pop("validation", None)
    (tmp_path / "bad.json").write_text(json.dumps(data))
    code = main(["check", "--robot", str(tmp_path / "bad.json"), "--log", str(tmp_path / "c.csv"),
                 "--measurements", str(root / "meas.csv")])
    err = capsys.readouterr().err
    assert code == 1 and "calibration.statistics.sigma_hat" in err and len(err.strip().splitlines()) == 1
    assert "internal error" not in err


def test_the_points_of_a_measurements_file_are_judged_with_their_own_sigma(cell, tmp_path, capsys):
    """`measure` writes each point's σ (sx, sy, sz): a check of that file gives each point the
    limit its own σ gives (above the calibration's noise), so the least precise point gets the
    widest limit."""
    from app.jobs.check_sources import measurement_file
    from core.measurement.file import read_measurements
    from core.measurement.point import point_covariance
    root, ds, calibrated, lab = cell
    meas = read_measurements(root / "meas.csv")
    source = measurement_file(read_robot(calibrated), root / "meas.csv", "marker")
    first = source.measure(source.Q[0])
    np.testing.assert_allclose(np.sqrt(np.diag(point_covariance(first))), meas.sigma[0], rtol=1e-12)
    code, data, err = run_json(capsys, ["check", "--robot", str(calibrated), "--log", str(tmp_path / "c.csv"),
                                        "--measurements", str(root / "meas.csv")])
    assert code in (0, 3), err
    limits = np.array([p["limit_mm"] for p in data["poses"]])
    own = np.linalg.norm(meas.sigma, axis=1)
    assert int(np.argmax(limits)) == int(np.argmax(own))
    assert np.corrcoef(own, limits)[0, 1] > 0.5            # measured 0.71 (lab seed 3, 36 poses)
