"""The Pose sequence page driven by pytest-qt: select on a worker thread, table, plot, views,
output for the Measurement step, cancel, bad input, autopilot."""
from __future__ import annotations

import numpy as np
import pytest
from PySide6.QtCore import Qt

from app.pages.poses.page import PosesPage
from app.pages.registry import PAGES
from app.pages.steps import Step
from app.state import WizardState
from app.worker import TaskRunner
from core.poses.candidates import arm_polyline
from core.poses.file import read_poses, write_poses

@pytest.fixture
def page(qtbot, boxes):
    state, tasks = WizardState(), TaskRunner()
    state.temporary_project()
    state.choose_preset("educational_6r")
    p = PosesPage(state, tasks)
    qtbot.addWidget(p)
    p.resize(900, 860)
    p.show()
    yield p
    tasks.shutdown()
    state.close()


def select(qtbot, page, count=12, candidates=300):
    page.count_spin.setValue(count)
    page.candidates_spin.setValue(candidates)
    qtbot.mouseClick(page.select_button, Qt.MouseButton.LeftButton)
    assert page.task.busy and not page.select_button.isEnabled() and page.cancel_button.isEnabled()
    qtbot.waitUntil(lambda: not page.task.busy, timeout=60000)


def test_registered_for_the_pose_step():
    assert PAGES[Step.POSES] is PosesPage


def test_select_fills_table_plot_views_and_output(qtbot, page, tmp_path):
    assert not page.is_complete()
    with qtbot.waitSignal(page.completeChanged, timeout=60000):
        select(qtbot, page)
    r = page.result
    assert r is not None and page.is_complete() and len(r.Q) == 12
    # the table: pose, q1..q6 in degrees, marker depth
    t = page.table
    assert t.rowCount() == 12 and t.columnCount() == 8
    headers = [t.horizontalHeaderItem(c).text() for c in range(8)]
    assert headers == ["Pose", "q1 (°)", "q2 (°)", "q3 (°)", "q4 (°)", "q5 (°)", "q6 (°)", "Depth (mm)"]
    assert [float(t.item(3, c).text()) for c in range(1, 7)] == pytest.approx(r.q_file[3], abs=1e-3)
    assert 400 <= float(t.item(0, 7).text()) <= 900
    # the plot: the index versus N with the random median, N marked
    x, y = page.curve_plot.selected_curve.getData()
    assert len(x) >= 10 and x[0] == r.n_min and 12 in x
    xr, yr = page.curve_plot.random_curve.getData()
    assert len(xr) == len(x) and np.all(y < yr)
    assert page.curve_plot.chosen_line.isVisible() and page.curve_plot.chosen_line.value() == 12
    assert "condition number" in page.curve_plot.plot_item.getAxis("left").labelText
    assert "number of poses" in page.curve_plot.plot_item.getAxis("bottom").labelText
    # the comparison with random selection
    assert "random selections" in page.summary.text() and "better" in page.summary.text()
    assert "Travel from home" in page.facts.text()
    # the views: cameras, selected markers, the arm of the highlighted (first) pose
    for view in page.views.views:
        assert len(view.selected.data) == 12 and len(view.cameras.data) == 2 and len(view._wedges) == 2
        assert len(view.candidates.data) == 300
    arm = page.views.top.arm.getData()
    expected, _ = arm_polyline(r.robot, r.Q[:1], "marker")
    np.testing.assert_allclose(arm[0], expected[0, :, 0])
    np.testing.assert_allclose(arm[1], expected[0, :, 2])
    page.highlight(5)
    expected, _ = arm_polyline(r.robot, r.Q[5:6], "marker")
    np.testing.assert_allclose(page.views.side.arm.getData()[0], expected[0, :, 2])
    np.testing.assert_allclose(page.views.side.arm.getData()[1], expected[0, :, 1])
    # the output for the Measurement step: in memory and as the project's poses.csv
    assert page.state.poses is r
    poses = read_poses(page.state.project.path("poses"), page.state.robot)
    np.testing.assert_allclose(poses.Q, r.Q, atol=1e-9)
    assert "poses.csv" in page.status.text()
    # another index shows its own curve for the same selection (linear axis)
    page.set_index("O3")
    assert not page.curve_plot.log_y and "O3" in page.curve_plot.plot_item.getAxis("left").labelText
    shot = tmp_path / "poses-page.png"
    page.grab().save(str(shot))
    assert shot.stat().st_size > 10000


def test_cancel_keeps_nothing(qtbot, page):
    page.count_spin.setValue(12)
    page.candidates_spin.setValue(2000)
    page.start_selection()
    page.task.cancel()
    qtbot.waitUntil(lambda: not page.task.busy, timeout=60000)
    assert page.result is None and not page.is_complete()
    assert page.status.text().startswith("Cancelled") and page.select_button.isEnabled()


def test_too_few_poses_says_the_minimum(qtbot, page, boxes):
    select(qtbot, page, count=5, candidates=100)
    assert not page.is_complete()
    assert "at least 9 poses" in page.status.text() and page.status.text().startswith("✗")
    assert boxes == []


def test_robot_change_clears_the_selection(qtbot, page):
    select(qtbot, page, count=10, candidates=200)
    assert page.is_complete()
    page.state.choose_preset("puma560")
    assert page.result is None and page.table.rowCount() == 0 and not page.is_complete()


def test_poses_file_in_the_project_counts(qtbot, boxes):
    state, tasks = WizardState(), TaskRunner()
    try:
        state.temporary_project()
        state.choose_preset("educational_6r")
        write_poses(state.project.path("poses"), np.zeros((3, 6)))
        page = PosesPage(state, tasks)
        qtbot.addWidget(page)
        page.on_enter()
        assert page.is_complete() and page.result is None and page.table.rowCount() == 3
    finally:
        tasks.shutdown()
        state.close()


def test_autopilot_selects_the_demo_poses(qtbot, page):
    outcome = []
    page.autopilot(lambda ok=True, message="": outcome.append((ok, message)))
    qtbot.waitUntil(lambda: bool(outcome), timeout=90000)
    ok, message = outcome[0]
    assert ok, message
    assert len(page.result.Q) == 30 and len(page.result.candidates) == 1000
    assert "κ" in message and page.state.project.has("poses")


def test_the_selection_runs_in_the_state_lab(qtbot, page):
    select(qtbot, page, count=10, candidates=200)
    assert page.state.labs.built and page.result.robot is page.state.labs.ready_now().nominal_robot
    assert page.result.depth is not None                 # the lab's cameras constrained the candidates


def test_cancel_a_running_selection(qtbot, page):
    page.state.labs.when_ready(lambda lab: None)
    qtbot.waitUntil(lambda: page.state.labs.built, timeout=60000)
    page.count_spin.setValue(12)
    page.candidates_spin.setValue(2000)
    assert page.start_selection() and page.task.handle is not None     # the lab exists: the selection itself runs
    page.task.cancel()
    qtbot.waitUntil(lambda: not page.task.busy, timeout=60000)
    assert page.result is None and page.status.text().startswith("Cancelled") and page.select_button.isEnabled()


def test_robot_change_while_the_lab_is_built_drops_the_selection(qtbot, page):
    assert page.start_selection() and page.task.busy and not page.state.labs.built
    page.state.choose_preset("puma560")
    assert not page.task.busy and page.select_button.isEnabled()
    page.state.labs.when_ready(lambda lab: None)                 # the lab of the new robot
    qtbot.waitUntil(lambda: page.state.labs.built, timeout=60000)
    assert page.result is None and not page.task.busy and "Select poses" in page.status.text()
