"""The Check step's model (Qt-free) and the controls' options: options heard only when changed,
each outcome heard as the event its panel draws, check poses kept for what they were chosen for,
and the controls' options shown back as chosen; the page's model follows its controls."""
from __future__ import annotations

from types import SimpleNamespace

import pytest

from app.pages.check.controls_panel import CheckControls
from app.pages.check.model import CheckModel, CheckOptions
from core.monitoring.log import CheckLog, LoggedCheck
from tests.app.pages.model_events import heard


def test_options_are_heard_only_when_they_change():
    model = CheckModel()
    events = heard(model, "options")
    model.set_options(CheckOptions())
    assert events == [] and model.options.count == 8
    model.set_options(CheckOptions(count=5, schedule_minutes=3))
    assert events == [("options", CheckOptions(count=5, schedule_minutes=3))]


def test_each_outcome_is_heard_as_what_is_drawn():
    model = CheckModel()
    events = heard(model, "poses", "check", "cleared", "log", "fixture")
    cell, other = SimpleNamespace(Q=[0, 1]), SimpleNamespace(Q=[2])
    key = ("calibrated.json", 1, 8, None)
    model.take_cell(cell, key)
    assert model.result.cell_for(key) is cell and model.result.cell_for(("calibrated.json", 2, 8, None)) is None
    result = SimpleNamespace(within=False)
    diagnosis = SimpleNamespace(explained=True, parameters=["marker.x"])
    model.take_check(other, result, diagnosis, key)          # a check at other poses takes them
    assert [e for e, _ in events] == ["poses", "poses", "check"]
    assert model.result.cell is other and model.result.check is result and model.result.can_reidentify
    model.take_check(other, result, None, key)               # the same poses: no new "poses"
    assert [e for e, _ in events][3:] == ["check"] and not model.result.can_reidentify
    model.take_log(None)
    assert events[-1] == ("log", None) and model.result.next_seed() == 1 and not model.result.complete
    log = CheckLog([LoggedCheck("1"), LoggedCheck("2", rms_mm=0.1, rms_limit_mm=0.2, within=True)], dof=6)
    model.take_log(log)
    assert model.result.next_seed() == 3 and model.result.complete
    run = SimpleNamespace(name="fixture")
    model.take_fixture(run)
    assert events[-1] == ("fixture", run)
    model.clear()
    assert events[-1][0] == "cleared" and model.result.cell is None and model.result.check is None
    assert model.result.fixture_run is run and model.result.log is log      # not the calibration's


@pytest.mark.parametrize("options", [
    CheckOptions(count=5, change="joint3:-0.4", payload_kg=2.5, schedule_minutes=7),
    CheckOptions(count=12, change="base:2"),
    CheckOptions(count=3, change="link2:1.25", schedule_minutes=60),
])
def test_the_controls_show_back_the_options_they_give(qtbot, options):
    controls = CheckControls()
    qtbot.addWidget(controls)
    changed = []
    controls.optionsChanged.connect(lambda: changed.append(controls.options()))
    controls.show_options(options)
    assert controls.options() == options and changed[-1] == options


def test_the_page_model_follows_its_controls_and_the_schedule_the_model(qtbot, tmp_path):
    from app.pages.check.page import CheckPage
    from app.state import WizardState
    from app.worker import TaskRunner

    state, tasks = WizardState(), TaskRunner()
    try:
        state.new_project(tmp_path / "project")
        state.choose_preset("educational_6r")
        page = CheckPage(state, tasks)
        qtbot.addWidget(page)
        page.controls.count_spin.setValue(6)
        page.controls.choose_change("joint", 0.5, joint=2)
        page.controls.payload_check.setChecked(True)
        page.controls.payload_spin.setValue(1.5)
        assert page.model.options == CheckOptions(count=6, change="joint2:0.5", payload_kg=1.5)
        page.controls.allow_schedule(None, False)
        page.controls.minutes_spin.setValue(4)
        page.controls.schedule_check.setChecked(True)
        assert page.model.options.schedule_minutes == 4 and page.schedule_timer.interval() == 4 * 60_000
        page.controls.count_spin.setValue(7)                 # another option: the timer runs on
        assert page.schedule_timer.isActive() and page.schedule_timer.interval() == 4 * 60_000
        page.controls.schedule_check.setChecked(False)
        assert page.model.options.schedule_minutes is None and not page.schedule_timer.isActive()
    finally:
        tasks.shutdown()
        state.close()
