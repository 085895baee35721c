"""The Measurement page driven by pytest-qt on the virtual lab: a run that is cancelled after a
few poses keeps every measurement on disk; resuming continues without losing or repeating
any; pause and continue; a pose outside the joint limits is refused and reported; the Stop
key stops the robot and the run, and nothing more is sent; start over moves the files aside;
the autopilot."""
from __future__ import annotations

import numpy as np
import pytest
from PySide6.QtCore import Qt
from PySide6.QtWidgets import QApplication

from app.jobs.measurement import MEASURED, PENDING, REJECTED
from app.pages.measurement.page import MeasurementPage
from app.pages.registry import PAGES
from app.pages.steps import Step
from app.worker import TaskRunner
from core.measurement.run import read_rejects, rejects_path_for
from core.measurement.file import read_measurements
from core.poses.file import write_poses
from tests.app.virtual_inputs import lab_marker, lab_state, make_lab
from tests.app.windows import close_window

N_POSES = 10


@pytest.fixture(scope="module")
def lab():
    return make_lab()


@pytest.fixture(scope="module")
def trained(lab):
    return lab_marker(lab)


@pytest.fixture(scope="module")
def q_file(lab):
    Q = lab.random_visible_poses(N_POSES, np.random.default_rng(5))
    return lab.nominal_robot.q_to_file(Q)


def ready_state(lab, trained, q_file):
    state = lab_state(lab)
    trained.save(state.project.folder / "marker.npz")
    write_poses(state.project.path("poses"), q_file)
    return state


@pytest.fixture
def page(qtbot, lab, trained, q_file, boxes):
    state, tasks = ready_state(lab, trained, q_file), TaskRunner()
    p = MeasurementPage(state, tasks)
    qtbot.addWidget(p)
    p.resize(900, 760)
    p.show()
    p.on_enter()
    yield p
    tasks.shutdown()
    state.close()


def measured_ids(page) -> list[int]:
    path = page.measurements_path()
    if not path.is_file():
        return []
    return [int(p) for p in read_measurements(path).pose]


def page_ids(page, status=MEASURED) -> list[int]:
    return [r.pose for r in page.rows if r.status == status]


def test_registered_for_the_measurement_step():
    assert PAGES[Step.MEASUREMENT] is MeasurementPage


@pytest.mark.no_session_cache          # the run must still be under way when Cancel is clicked
def test_cancel_keeps_every_measurement_and_resume_continues(qtbot, page, boxes):
    assert page.poses is not None and len(page.rows) == N_POSES and not page.is_complete()
    assert page.n_min == 9                                  # 25 identifiable parameters, 3 equations per pose
    assert "poses.csv" in page.controls.source_label.text() and "stereo.yaml" in page.controls.source_label.text()
    assert page.controls.start_button.text() == "Start"
    qtbot.mouseClick(page.controls.start_button, Qt.MouseButton.LeftButton)
    assert page.task.busy and page.task.progress_row().cancel_button.isEnabled() and page.controls.pause_button.isEnabled()
    qtbot.waitUntil(lambda: len(page_ids(page)) >= 2, timeout=30000)
    # each pose shown as measured is already on disk (written and flushed per pose)
    assert set(page_ids(page)) <= set(measured_ids(page))
    qtbot.mouseClick(page.task.progress_row().cancel_button, Qt.MouseButton.LeftButton)
    qtbot.waitUntil(lambda: not page.task.busy, timeout=30000)
    first = measured_ids(page)
    assert 2 <= len(first) < N_POSES
    assert sorted(page_ids(page)) == sorted(first)          # the table is the file
    assert page.result.cancelled and "Cancelled" in page.status.text() and "Measure the rest" in page.status.text()
    assert page.controls.start_button.text() == "Measure the rest" and page.controls.start_button.isEnabled()
    pending = page_ids(page, PENDING)
    assert pending and len(pending) + len(first) + len(page_ids(page, REJECTED)) == N_POSES
    rows_before = {p: page.rows[page.model.row_of(p)].point.copy() for p in first}
    # resume: the rest is measured, nothing twice, nothing lost
    qtbot.mouseClick(page.controls.start_button, Qt.MouseButton.LeftButton)
    qtbot.waitUntil(lambda: not page.task.busy, timeout=60000)
    r = page.result
    assert not r.cancelled and sorted(o.pose for o in r.skipped) == sorted(first)
    ids = measured_ids(page)
    assert len(ids) == len(set(ids))                          # no pose twice
    assert set(first) <= set(ids)                             # none lost
    assert len(ids) + len(read_rejects(rejects_path_for(page.measurements_path()))) == N_POSES
    for p in first:                                           # the earlier points are kept as they were
        np.testing.assert_allclose(page.rows[page.model.row_of(p)].point, rows_before[p], atol=1e-3)
    assert not page_ids(page, PENDING) and len(ids) >= N_POSES - 1
    assert not page.controls.start_button.isEnabled()                  # nothing left to measure
    # the points drawn in both views, the current pair as a thumbnail, the summary
    for view in page.views.views:
        assert len(view.selected.data) == len(ids) and len(view.cameras.data) == 2
    assert page.pair.thumb.image_shape()[1] > 600
    assert f"<b>{len(ids)}</b> measured" in page.summary.text()
    assert "Identification needs at least" in page.summary.text()
    assert page.state.measurements == page.measurements_path()
    assert boxes == []


@pytest.mark.no_session_cache          # the run must still be under way when it is paused
def test_pause_and_continue(qtbot, page):
    assert page.start_run()
    qtbot.waitUntil(lambda: len(page_ids(page)) >= 1, timeout=30000)
    page.pause()
    assert page.paused and page.controls.pause_button.text() == "Continue"
    qtbot.waitUntil(lambda: "paused" in page.task.progress_row().bar.format(), timeout=30000)
    done = len(measured_ids(page))
    qtbot.wait(600)
    assert page.task.busy and len(measured_ids(page)) == done        # nothing measured while paused
    page.pause(False)
    assert not page.paused
    qtbot.waitUntil(lambda: not page.task.busy, timeout=60000)
    assert not page.result.cancelled and not page_ids(page, PENDING)


def test_pose_outside_the_joint_limits_is_refused_and_reported(qtbot, page, q_file, tmp_path):
    bad = np.array(q_file[:3], dtype=float)
    bad[1, 1] = 400.0                                         # J2 far outside its limits
    path = tmp_path / "mixed.csv"
    write_poses(path, bad)
    assert page.load_csv(path)
    assert len(page.rows) == 3 and "mixed.csv" in page.controls.source_label.text()
    robot = page.state.hardware.robot_connection
    moves = robot.move_count
    assert page.start_run()
    qtbot.waitUntil(lambda: not page.task.busy, timeout=60000)
    row = page.rows[1]
    assert row.status == REJECTED and "outside its limits" in row.reason and "not moved" in row.reason
    assert robot.move_count == moves + 2                      # the refused pose sent nothing
    rejects = read_rejects(rejects_path_for(page.measurements_path()))
    assert 1 in rejects and "outside its limits" in rejects[1][2]
    assert "rejected" in page.table.item(1, 5).text()
    assert "outside its limits" in page.table.item(1, 5).toolTip()
    assert "1</b> rejected" in page.summary.text() and "outside its limits" in page.summary.text()


def test_start_over_moves_the_files_aside(qtbot, page):
    assert page.start_run()
    qtbot.waitUntil(lambda: not page.task.busy, timeout=60000)
    n = len(measured_ids(page))
    assert page.start_over(confirm=False)
    folder = page.state.project.folder
    old = sorted(folder.glob("measurements.old-*.csv"))
    assert len(old) == 1 and len(read_measurements(old[0]).pose) == n         # kept, not deleted
    assert not page.measurements_path().exists()
    assert all(r.status == PENDING for r in page.rows) and page.controls.start_button.text() == "Start"


def test_missing_inputs_are_said(qtbot, lab, q_file, boxes):
    state, tasks = lab_state(lab), TaskRunner()
    try:
        write_poses(state.project.path("poses"), q_file)
        page = MeasurementPage(state, tasks)
        qtbot.addWidget(page)
        assert not page.start_run()
        assert "no trained marker" in page.status.text() and "step 3" in page.status.text()
    finally:
        tasks.shutdown()
        state.close()


@pytest.mark.no_session_cache          # the run must still be under way when the key is pressed
def test_stop_key_stops_the_robot_and_the_run(qtbot, lab, trained, q_file, boxes):
    from app.main_window import MainWindow

    state = ready_state(lab, trained, q_file)
    win = MainWindow(state)
    qtbot.addWidget(win)
    try:
        win.show()
        page = win.go_to(Step.MEASUREMENT)
        robot = state.hardware.robot_connection
        assert page.start_run()
        qtbot.waitUntil(lambda: len(page_ids(page)) >= 1, timeout=30000)
        win.activateWindow()
        qtbot.waitUntil(lambda: QApplication.activeWindow() is win, timeout=5000)
        qtbot.keyClick(win, Qt.Key.Key_Escape)
        assert robot.stopped                     # stop() returned: no move is under way, none follows
        moves_at_stop = robot.move_count
        qtbot.waitUntil(lambda: not page.task.busy, timeout=30000)
        assert robot.move_count == moves_at_stop                 # nothing more sent after Stop
        assert "Robot stopped" in page.status.text() and "Resume after stop" in page.status.text()
        first = measured_ids(page)
        assert first and sorted(first) == sorted(page_ids(page)) and page_ids(page, PENDING)
        # a stopped robot is not started again by the page
        assert not page.start_run() and "stopped" in page.status.text()
        win.resume_robot()
        assert page.start_run()
        qtbot.waitUntil(lambda: not page.task.busy, timeout=60000)
        ids = measured_ids(page)
        assert len(ids) == len(set(ids)) and set(first) <= set(ids) and not page_ids(page, PENDING)
    finally:
        close_window(win)


def test_autopilot_measures_the_poses(qtbot, page):
    outcome = []
    page.autopilot(lambda ok=True, message="": outcome.append((ok, message)))
    qtbot.waitUntil(lambda: bool(outcome), timeout=90000)
    ok, message = outcome[0]
    assert ok, message
    assert "measured" in message and "needs 9" in message and page.is_complete()
    ids = measured_ids(page)
    assert len(ids) >= 9 and len(set(ids)) == len(ids)
    # run again: everything is done, the autopilot finishes at once without measuring twice
    again = []
    page.autopilot(lambda ok=True, message="": again.append((ok, message)))
    assert again and again[0][0] and measured_ids(page) == ids


def test_measurements_of_another_pose_list_are_not_counted(qtbot, page, q_file):
    assert page.start_run()
    qtbot.waitUntil(lambda: not page.task.busy, timeout=60000)
    assert page.is_complete()
    other = np.array(q_file, dtype=float)
    other[:, 0] += 1.0                                        # the same pose numbers, other joint values
    write_poses(page.state.project.path("poses"), other)
    page.on_enter()
    assert not page_ids(page) and not page.is_complete()
    assert "another pose list" in page.status.text() and page.controls.over_button.isEnabled()
    assert page.start_run()                                       # the run refuses the file and says why
    qtbot.waitUntil(lambda: not page.task.busy, timeout=60000)
    assert "another pose list" in page.status.text() and "Start over" in page.status.text()
    assert page.start_over(confirm=False) and page.start_run()
    qtbot.waitUntil(lambda: not page.task.busy, timeout=60000)
    assert len(page_ids(page)) >= 9
