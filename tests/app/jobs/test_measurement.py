"""The Measurement step's jobs with plain arguments: which pose list to measure, the virtual-lab
run, the status of each pose read back from the files, moving files aside, the nominal model's
predictions."""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from app.jobs.measurement import (MEASURED, PENDING, REJECTED, THUMB_WIDTH, choose_pose_list, measure_virtual,
                                  move_aside, nominal_arm, nominal_predictions, pose_rows, poses_needed)
from core.errors import RoboCalError
from core.marker.correspondence import StereoRectification
from core.measurement.file import Measurements, write_measurements
from core.measurement.run import RejectsWriter, poses_from_internal, rejects_path_for
from core.poses.file import write_poses
from core.poses.selection import minimum_poses
from core.robot.simulated import SimulatedRobot
from tests.app.virtual_inputs import lab_marker, make_lab


@pytest.fixture(scope="module")
def lab():
    return make_lab()


@pytest.fixture(scope="module")
def poses(lab):
    return poses_from_internal(lab.random_visible_poses(4, np.random.default_rng(3)), lab.nominal_robot)


def measurements_of(poses, rows, q_shift=0.0) -> Measurements:
    q = np.asarray(poses.q_file, float)[rows] + q_shift
    xyz = np.arange(3 * len(rows), dtype=float).reshape(-1, 3) + 100.0
    return Measurements(pose=np.asarray(poses.pose)[rows], target=["marker"] * len(rows), q_file=q, Q=None,
                        xyz=xyz, sigma=np.full((len(rows), 3), 0.02))


def test_the_pose_list_a_loaded_csv_else_the_projects_else_the_selection(lab, poses, tmp_path):
    robot = lab.nominal_robot
    selection = SimpleNamespace(q_file=poses.q_file[:3], Q=poses.Q[:3], n_min=7)
    loaded = write_poses(tmp_path / "mine.csv", poses.q_file[:2])
    project = write_poses(tmp_path / "poses.csv", poses.q_file)
    chosen, where, problem = choose_pose_list(robot, loaded_csv=loaded, project_poses=project, selection=selection)
    assert (len(chosen), where, problem) == (2, "2 poses from mine.csv", "")
    chosen, where, problem = choose_pose_list(robot, loaded_csv=None, project_poses=project, selection=selection)
    assert (len(chosen), where, problem) == (4, "4 poses from the project's poses.csv", "")
    np.testing.assert_allclose(chosen.Q, poses.Q, atol=1e-9)
    chosen, where, problem = choose_pose_list(robot, loaded_csv=None, project_poses=None, selection=selection)
    assert (len(chosen), where, problem) == (3, "3 poses from the Pose sequence step", "")
    assert chosen.pose.tolist() == [0, 1, 2]
    assert choose_pose_list(robot, loaded_csv=None, project_poses=None, selection=None)[2].startswith("No pose list")
    broken = write_poses(tmp_path / "three.csv", np.zeros((2, 3)))
    chosen, where, problem = choose_pose_list(robot, loaded_csv=broken, project_poses=project, selection=selection)
    assert chosen is None and where == "" and problem.startswith("The pose list cannot be used:")
    assert "three.csv" in problem


def test_poses_needed_the_selections_figure_else_the_robots(lab):
    robot = lab.nominal_robot
    assert poses_needed(robot, SimpleNamespace(n_min=7)) == 7
    assert poses_needed(robot, None) == poses_needed(robot, SimpleNamespace(n_min=0)) == minimum_poses(robot) > 0


def test_rows_read_back_from_the_measurements_and_rejects_files(poses, tmp_path):
    path = tmp_path / "measurements.csv"
    rows, problem = pose_rows(poses, path)                    # no files yet: every pose pending
    assert problem == "" and [r.status for r in rows] == [PENDING] * 4 and [r.pose for r in rows] == [0, 1, 2, 3]
    write_measurements(measurements_of(poses, [0, 2]), path)
    rejects = RejectsWriter(rejects_path_for(path), poses.q_file.shape[1])
    rejects.append(3, "marker", poses.q_file[3], "marker not found in the right image")
    rejects.close()
    rows, problem = pose_rows(poses, path)
    assert problem == "" and [r.status for r in rows] == [MEASURED, PENDING, MEASURED, REJECTED]
    np.testing.assert_allclose(rows[2].point, [103.0, 104.0, 105.0])
    np.testing.assert_allclose(rows[0].sigma, [0.02] * 3)
    assert rows[3].reason == "marker not found in the right image" and rows[3].point is None


def test_a_file_of_another_pose_list_leaves_every_pose_pending(poses, tmp_path):
    path = write_measurements(measurements_of(poses, [0, 1], q_shift=1.0), tmp_path / "measurements.csv")
    rows, problem = pose_rows(poses, path)
    assert "belongs to another pose list" in problem and "pose 0" in problem
    assert all(r.status == PENDING and r.point is None for r in rows)
    path.write_text("not a measurements file\n")
    rows, problem = pose_rows(poses, path)
    assert problem and len(rows) == 4
    assert pose_rows(None, path) == ([], "")


def test_move_aside_keeps_every_file_and_never_overwrites(tmp_path):
    a, b = tmp_path / "measurements.csv", tmp_path / "measurements.rejects.csv"
    a.write_text("a")
    b.write_text("b")
    (tmp_path / "measurements.old-20260101-120000.csv").write_text("older")
    moved = move_aside([a, b], "20260101-120000")
    assert [p.name for p in moved] == ["measurements.old-20260101-120000-1.csv",
                                       "measurements.rejects.old-20260101-120000.csv"]
    assert not a.exists() and not b.exists() and [p.read_text() for p in moved] == ["a", "b"]
    assert (tmp_path / "measurements.old-20260101-120000.csv").read_text() == "older"
    with pytest.raises(RoboCalError, match="cannot move gone.csv aside"):
        move_aside([tmp_path / "gone.csv"])


def test_predictions_and_arms_of_the_nominal_model(lab, poses):
    predicted, arms = nominal_predictions(lab, poses.Q)
    n = lab.nominal_robot.dof
    assert predicted.shape == (4, 3) and arms.shape == (4 * (2 * n + 3), 3)
    for i in range(4):
        arm = nominal_arm(lab, poses.Q[i])
        np.testing.assert_allclose(arm, arms[i * (2 * n + 3):(i + 1) * (2 * n + 3)])
        np.testing.assert_allclose(arm[-1], predicted[i], atol=1e-9)      # the arm ends at the marker


def test_the_virtual_run_measures_reports_and_stops_with_the_robot(lab, poses, tmp_path):
    trained = lab_marker(lab)
    rect = StereoRectification.from_rig(lab.rig)
    robot = SimulatedRobot(lab.true_robot)
    robot.connect()
    reported = []
    out = tmp_path / "measurements.csv"
    result = measure_virtual(poses, out, trained, rect, robot, lab, 0,
                             report=lambda outcome, thumb: reported.append((outcome, thumb)))
    assert not result.cancelled and len(result.measured) + len(result.rejected) == 4 and len(result.measured) >= 3
    assert [o.pose for o, _ in reported] == [0, 1, 2, 3]
    assert all(thumb.shape[1] > 2 * THUMB_WIDTH and thumb.shape[2] == 3 for _, thumb in reported)
    rows, _ = pose_rows(poses, out)
    assert [r.status == MEASURED for r in rows] == [o.status == "measured" for o, _ in reported]
    for o, _ in reported:                                      # within a few mm of the true marker position
        if o.status == "measured":
            true = lab.true_robot.target_positions(poses.Q[o.index][None], lab.target)[0]
            assert np.linalg.norm(o.point - true) < 5.0
    # a robot stopped by the user ends the next run before its first pose, like a cancel
    robot.stop()
    moves = robot.move_count
    again = measure_virtual(poses, tmp_path / "other.csv", trained, rect, robot, lab, 0)
    assert again.cancelled and not again.measured and robot.move_count == moves
