"""The Measurement page's Qt-free model: the pose list chosen (loaded CSV, project's poses, none),
each pose's status read back from measurements.csv and its rejects file, the events the panels
redraw from (rows, a pose being measured, a pose done), and the options heard only on a change."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from app.jobs.measurement import MEASURED, PENDING, REJECTED, RUNNING
from app.pages.measurement.model import MeasurementModel, MeasurementOptions, PoseShown
from core.measurement.file import Measurements, write_measurements
from core.measurement.run import PoseOutcome, RejectsWriter, rejects_path_for
from core.poses.file import write_poses
from core.poses.selection import minimum_poses
from core.robot.file import read_robot


@pytest.fixture(scope="module")
def robot():
    return read_robot("educational_6r")


@pytest.fixture
def q_file(robot):
    lo, hi = robot.limits()
    fractions = np.array([0.3, 0.4, 0.5, 0.6])[:, None]
    return robot.q_to_file(lo + (hi - lo) * fractions)           # 4 poses inside the limits, deg


def heard(model: MeasurementModel) -> dict[str, list]:
    events: dict[str, list] = {name: [] for name in ("options", "rows", "row", "pose")}
    for name, values in events.items():
        model.on(name, values.append)
    return events


def test_rows_come_from_the_files_and_change_as_poses_are_measured(robot, q_file, tmp_path):
    poses_csv, path = write_poses(tmp_path / "poses.csv", q_file), tmp_path / "measurements.csv"
    model = MeasurementModel()
    events = heard(model)
    assert model.choose_poses(robot, poses_csv, None) == ""
    assert model.poses_label == "4 poses from the project's poses.csv" and model.n_min == minimum_poses(robot)
    model.read_rows(path)                                           # nothing measured yet
    assert [r.status for r in model.rows] == [PENDING] * 4 and len(events["rows"]) == 1
    assert model.next_pose_text() == "0" and model.n_measured == 0

    write_measurements(Measurements(pose=np.array([0, 2]), target=["marker"] * 2, q_file=q_file[[0, 2]], Q=None,
                                    xyz=np.array([[1.0, 2.0, 3.0], [4.0, 5.0, 6.0]]),
                                    sigma=np.full((2, 3), 0.02)), path)
    rejects = RejectsWriter(rejects_path_for(path), q_file.shape[1])
    rejects.append(3, "marker", q_file[3], "marker not found in the right image")
    rejects.close()
    model.read_rows(path)
    assert [r.status for r in model.rows] == [MEASURED, PENDING, MEASURED, REJECTED] and model.file_problem == ""
    np.testing.assert_allclose(model.rows[2].point, [4.0, 5.0, 6.0])
    assert [r.pose for r in model.pending()] == [1] and model.next_pose_text() == "1" and model.n_measured == 2

    model.mark_running(1)
    model.mark_running(1)                          # already being measured: no second event
    model.mark_running(99)                         # not a pose of this list
    assert events["row"] == [1] and model.rows[1].status == RUNNING and model.row_of(1) == 1

    thumb = np.zeros((4, 8, 3), np.uint8)
    model.record(PoseOutcome(index=1, pose=1, q_file=q_file[1], status="measured",
                             point=np.array([7.0, 8.0, 9.0]), sigma=np.full(3, 0.03)), thumb)
    model.record(PoseOutcome(index=0, pose=99, q_file=q_file[0], status="rejected", reason="elsewhere"))
    assert len(events["pose"]) == 1
    shown = events["pose"][0]
    assert isinstance(shown, PoseShown) and shown.index == 1 and shown.thumbnail is thumb
    assert shown.row.status == MEASURED and np.allclose(shown.row.point, [7.0, 8.0, 9.0])
    assert not model.pending() and model.next_pose_text() == "–" and model.counts()[MEASURED] == 3
    assert model.done_message(path) == (f"3 poses measured, 1 rejected (identification needs {model.n_min}) "
                                        "→ measurements.csv")
    assert events["options"] == []


def test_a_loaded_csv_is_measured_instead_and_options_are_heard_on_a_change(robot, q_file, tmp_path):
    project_poses = write_poses(tmp_path / "poses.csv", q_file)
    loaded = write_poses(tmp_path / "mine.csv", q_file[:2])
    model = MeasurementModel()
    events = heard(model)
    model.set_options(MeasurementOptions(loaded_csv=Path(loaded)))
    model.set_options(MeasurementOptions(loaded_csv=Path(loaded)))                # the same: not heard again
    assert events["options"] == [MeasurementOptions(loaded_csv=Path(loaded))]
    assert model.choose_poses(robot, project_poses, None) == ""
    assert model.poses_label == "2 poses from mine.csv" and len(model.poses) == 2
    np.testing.assert_allclose(model.joints(), robot.q_from_file(q_file[:2]), atol=1e-9)
    assert model.choose_poses(None, project_poses, None) == "No project or robot yet (Setup step)."
    assert model.poses is None and model.poses_label == "" and model.joints() is None
    model.read_rows(tmp_path / "measurements.csv")
    assert model.rows == [] and events["rows"] == [[]]
