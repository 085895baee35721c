"""The Measurement page's panels on their own (pytest-qt, offscreen): the run controls and the
teach panel say what was chosen (`options()`) and bind it back (`show_options`); the table, the
pair and the summary redraw from the model's events."""
from __future__ import annotations

import numpy as np
import pytest

from app.pages.measurement.controls import RunControls
from app.pages.measurement.model import JointSource, MeasurementModel, RunSwitches
from app.pages.measurement.pair_view import PairView
from app.pages.measurement.pose_table import PoseTable
from app.pages.measurement.summary import SummaryLabel
from app.pages.measurement.teach_panel import TeachPanel
from core.measurement.run import PoseOutcome
from core.poses.file import write_poses
from core.robot.file import read_robot
from widgets.progress_row import ProgressRow


def test_run_controls_say_and_show_their_switches(qtbot):
    heard = {"pause": [], "teach": [], "load": []}
    controls = RunControls(ProgressRow(), on_load=heard["load"].append, folder=lambda: "", on_start=lambda: None,
                           on_pause=heard["pause"].append, on_start_over=lambda: None,
                           on_teach=heard["teach"].append)
    qtbot.addWidget(controls)
    assert controls.options() == RunSwitches(teach=False, paused=False)
    controls.teach_check.setChecked(True)                     # the technician ticks it: the page hears it
    assert heard["teach"] == [True] and controls.options().teach
    controls.show_options(RunSwitches(teach=False, paused=True))
    assert heard["teach"] == [True]                           # shown by the page: not told back
    assert heard["pause"] == [True] and controls.pause_button.text() == "Continue"
    assert controls.options() == RunSwitches(teach=False, paused=True)
    controls.show_options(RunSwitches(teach=False, paused=False))
    assert heard["pause"] == [True, False] and controls.pause_button.text() == "Pause"


def test_teach_panel_says_where_the_joints_come_from(qtbot):
    typed = []
    panel = TeachPanel(on_record=lambda: None, on_typed=typed.append, on_use_plan=lambda: None)
    qtbot.addWidget(panel)
    panel.show_options(JointSource(read_from_controller=False, typed="10 20 30"))
    assert panel.options() == JointSource(read_from_controller=False, typed="10 20 30") and typed == ["10 20 30"]
    panel.show_options(JointSource(read_from_controller=True, typed="10 20 30"))
    assert typed == ["10 20 30"]                              # the same text: no second check
    assert panel.options().read_from_controller and not panel.joints_edit.isEnabled()
    panel.joints_edit.clear()
    assert panel.options() == JointSource(read_from_controller=True, typed="")


@pytest.fixture
def model(tmp_path):
    robot = read_robot("educational_6r")
    lo, hi = robot.limits()
    q_file = robot.q_to_file(lo + (hi - lo) * np.array([0.4, 0.5, 0.6])[:, None])
    m = MeasurementModel()
    assert m.choose_poses(robot, write_poses(tmp_path / "poses.csv", q_file), None) == ""
    return m


def test_table_pair_and_summary_follow_the_model(qtbot, model, tmp_path):
    table, pair, summary = PoseTable(), PairView(), SummaryLabel()
    for panel in (table, pair, summary):
        qtbot.addWidget(panel)
        panel.follow(model)
    model.read_rows(tmp_path / "measurements.csv")
    assert table.rowCount() == 3 and table.item(0, 5).text() == "pending"
    assert "<b>0</b> measured" in summary.text() and "<b>3</b> pending of 3 poses" in summary.text()
    model.mark_running(1)
    assert table.item(1, 5).text() == "▶ measuring…"
    thumb = np.full((20, 60, 3), 128, np.uint8)
    model.record(PoseOutcome(index=1, pose=1, q_file=model.poses.q_file[1], status="rejected",
                             reason="marker not found in the left image"), thumb)
    assert "rejected: marker not found" in table.item(1, 5).text() and table.selected() == 1
    assert pair.thumb.image_shape()[1] == 60 and "Pose 1: left | right — rejected" in pair.label.text()
    assert "<b>1</b> rejected" in summary.text() and "marker not found in the left image" in summary.text()
