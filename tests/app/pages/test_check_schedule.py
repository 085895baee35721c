""""Check every N min" on the Check page is offered only where checks can run: not without a
calibrated robot, not on a real cell that cannot measure (no robot connected), not in teach mode;
the tooltip says why, and a schedule that was on is switched off."""
from __future__ import annotations

import pytest

from app.lab import ideal_lab_measurements
from app.pages.check.controls_panel import SCHEDULE_TIP
from app.pages.check.page import CheckPage
from app.state import WizardState
from app.worker import TaskRunner
from core import project as projects
from core.identification.file import write_calibrated_model
from core.identification.solver import identify
from tests.app.virtual_inputs import make_lab


@pytest.fixture(scope="module")
def lab():
    return make_lab()


def open_page(qtbot, state: WizardState, tasks: TaskRunner) -> CheckPage:
    page = CheckPage(state, tasks)
    qtbot.addWidget(page)
    page.resize(1100, 700)
    page.show()
    page.on_enter()
    return page


def write_calibration(lab, state: WizardState) -> None:
    meas = ideal_lab_measurements(lab, 40, sigma_mm=0.05, seed=4)
    write_calibrated_model(identify(lab.nominal_robot, meas), state.project.path("calibrated"))


def schedule(page):
    c = page.controls
    return c.schedule_check.isEnabled(), c.minutes_spin.isEnabled(), c.schedule_check.toolTip()


def test_no_schedule_without_a_calibrated_robot_then_offered(lab, qtbot, tmp_path):
    state, tasks = WizardState(), TaskRunner()
    try:
        state.new_project(tmp_path / "project")
        state.choose_preset("educational_6r")
        page = open_page(qtbot, state, tasks)
        enabled, minutes, tip = schedule(page)
        assert not enabled and not minutes
        assert tip == ("Checks cannot run on a schedule: the project has no calibrated robot (calibrated.json): "
                       "run the Identification step first.")
        assert page.controls.minutes_spin.toolTip() == tip
        write_calibration(lab, state)
        page.refresh()
        assert schedule(page) == (True, True, SCHEDULE_TIP)
        page.controls.schedule_check.setChecked(True)
        assert page.schedule_timer.isActive()
        page.controls.schedule_check.setChecked(False)
    finally:
        tasks.shutdown()
        state.close()


def test_no_schedule_on_a_real_cell_without_its_robot_and_a_running_one_is_switched_off(lab, qtbot, tmp_path):
    state, tasks = WizardState(), TaskRunner()
    try:
        state.new_project(tmp_path / "project", mode=projects.HARDWARE,
                          robot_connection={"kind": "serial", "port": "/dev/ttyUSB0", "profile": "robocal_v1"},
                          cameras={"kind": "sources", "left": str(tmp_path / "left"), "right": str(tmp_path / "right")})
        state.choose_preset("educational_6r")
        write_calibration(lab, state)
        page = open_page(qtbot, state, tasks)
        enabled, minutes, tip = schedule(page)
        assert not enabled and not minutes
        assert tip == ("Checks cannot run on a schedule: nothing can be measured: no robot is connected: connect "
                       "the cell's robot on the Setup page.")
        # a schedule switched on while it could run is switched off when the cell can no longer measure
        page.controls.allow_schedule(None, False)
        page.controls.schedule_check.setChecked(True)
        assert page.schedule_timer.isActive()
        page.refresh()
        assert not page.controls.schedule_check.isChecked() and not page.schedule_timer.isActive()
        assert not page.controls.schedule_check.isEnabled()
    finally:
        tasks.shutdown()
        state.close()


def test_no_schedule_in_teach_mode(lab, qtbot, tmp_path):
    state, tasks = WizardState(), TaskRunner()
    try:
        state.new_project(tmp_path / "project", mode=projects.HARDWARE, robot_connection={"kind": "teach"},
                          cameras={"kind": "sources", "left": str(tmp_path / "left"), "right": str(tmp_path / "right")})
        state.choose_preset("educational_6r")
        write_calibration(lab, state)
        page = open_page(qtbot, state, tasks)
        enabled, _, tip = schedule(page)
        assert not enabled and "in teach mode the robot is brought to every check pose by hand" in tip
    finally:
        tasks.shutdown()
        state.close()
