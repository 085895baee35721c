"""The Compensation step's jobs without the page: frames of a typed point, what kind of program a
file is, the predicted error only where a covariance exists, a corrected program never written
short, Go to point refusing a point the model cannot reach, and the accuracy map needing the
calibration's measurements."""
from __future__ import annotations

import numpy as np
import pytest

from app.jobs import compensation as job
from core.errors import RoboCalError
from core.identification.file import write_calibrated_model
from core.identification.solver import identify
from core.poses.file import write_poses
from core.robot.file import read_robot, write_robot
from core.virtual_lab.ideal_measurements import ideal_lab_measurements, write_ideal_measurements


@pytest.fixture(scope="module")
def lab(built_lab):
    return built_lab(seed=0, noise=0.5)


@pytest.fixture(scope="module")
def files(lab, tmp_path_factory):
    folder = tmp_path_factory.mktemp("cell")
    meas = ideal_lab_measurements(lab, 40, sigma_mm=0.05, seed=4)
    write_ideal_measurements(meas, folder / "measurements.csv", sigma_mm=0.05)
    write_calibrated_model(identify(lab.nominal_robot, meas), folder / "calibrated.json")
    return folder, meas


def test_frames_of_a_typed_point(tmp_path):
    assert job.frame_of("base") == "base" and job.frame_of("camera") == "measurement"
    with pytest.raises(RoboCalError, match="no located fixture"):
        job.frame_of("fixture", tmp_path / "fixture_pose.json")
    with pytest.raises(RoboCalError, match="unknown frame"):
        job.frame_of("world")


def test_a_program_file_says_what_it_holds(tmp_path):
    (tmp_path / "t.csv").write_text("# targets\nname,x,y,z\np1,1,2,3\n")
    write_poses(tmp_path / "j.csv", np.zeros((2, 6)))
    assert job.is_targets_file(tmp_path / "t.csv") and not job.is_targets_file(tmp_path / "j.csv")


def test_points_predicted_error_and_program(lab, files, tmp_path):
    folder, meas = files
    cell = job.load_cell(folder / "calibrated.json", lab.nominal_robot, folder / "measurements.csv")
    seen = lab.true_robot.target_positions(meas.Q[:2], "marker")
    points = job.compensate_points(cell, ["a", "b", "far"], np.vstack([seen, [[9000.0, 0.0, 0.0]]]), "measurement")
    assert [p.reachable for p in points] == [True, True, False]
    assert all(0 < p.predicted_mm < 0.5 for p in points[:2]) and np.isnan(points[2].predicted_mm)
    assert "out of reach" in points[2].note
    with pytest.raises(RoboCalError, match="1 point"):
        job.write_corrected_program(tmp_path / "out.csv", cell, points)
    assert not (tmp_path / "out.csv").exists()
    with pytest.raises(RoboCalError, match="cannot be reached"):
        job.go_to_point(points[2], lambda q: pytest.fail("the robot must not move"), "lab")
    # a robot file without the calibration's covariance: no predicted error, the joints still come
    plain = read_robot(folder / "calibrated.json")
    plain.calibration = None
    write_robot(plain, tmp_path / "plain.json")
    bare = job.load_cell(tmp_path / "plain.json", lab.nominal_robot)
    assert bare.unc is None and bare.measured_Q is None
    again = job.compensate_points(bare, ["a"], seen[:1], "measurement", hints=meas.Q[:1])
    assert again[0].reachable and np.isnan(again[0].predicted_mm)


def test_accuracy_map_needs_the_measurements(lab, files, tmp_path):
    folder, _ = files
    cell = job.load_cell(folder / "calibrated.json", lab.nominal_robot)
    with pytest.raises(RoboCalError, match="no measurements"):
        job.measure_accuracy_map(cell, tmp_path / "measurements.csv", lambda q: None, "lab", tmp_path)
    run = job.measure_accuracy_map(cell, folder / "measurements.csv", lambda q: None, "lab", tmp_path, count=4)
    assert run.path is None and not run.amap.both.any()                  # nothing measured: nothing written
    assert not (tmp_path / "accuracy_map.json").exists()
    assert all("marker not found" in n for n in run.amap.notes)
