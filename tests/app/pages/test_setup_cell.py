"""The project's cell: chosen when a project is made (virtual lab or a real cell with its robot
connection and cameras), saved in project.json, shown on the Setup page and changed from there;
the state's robot connection follows (the lab's simulated robot only in a virtual-lab project).
The dialog itself: tests/app/test_cell_dialog.py."""
from __future__ import annotations

import json

import pytest

from app import project_actions
from app.hardware import is_real
from app.pages.setup.page import SetupPage
from app.state import WizardState
from app.worker import TaskRunner
from core import project as projects


@pytest.fixture
def page(qtbot):
    state, tasks = WizardState(), TaskRunner()
    p = SetupPage(state, tasks)
    qtbot.addWidget(p)
    p.resize(1200, 900)
    p.show()
    yield p
    p.on_leave()
    tasks.shutdown()
    state.close()


def test_a_new_real_cell_project_is_saved_shown_and_changed(page, tmp_path):
    cell = (projects.HARDWARE, {"kind": "serial", "port": "/dev/ttyUSB0", "profile": "robocal_v1"},
            {"kind": "sources", "left": "0", "right": "1"})
    project = project_actions.new_project(page, page.state, tmp_path / "cell", cell)
    page.state.choose_preset("educational_6r")
    saved = json.loads((tmp_path / "cell" / "project.json").read_text())
    assert saved["mode"] == "hardware" and saved["robot_connection"]["port"] == "/dev/ttyUSB0"
    assert saved["cameras"] == {"kind": "sources", "left": "0", "right": "1"}
    assert page.state.real_cell and page.state.hardware.robot_connection is None      # never the lab's simulated robot
    assert "Cell: a real cell: the serial robot on /dev/ttyUSB0 (robocal_v1), cameras 0 and 1" in \
        page.project_details.text()
    assert page.robot_panel.port_edit.text() == "/dev/ttyUSB0" and page.robot_panel.serial_radio.isChecked()
    assert not page.robot_panel.virtual_radio.isEnabled()
    assert page.camera_panel.left_edit.text() == "0"

    assert page.change_cell((projects.VIRTUAL_LAB, None, None))
    assert projects.open_project(project.folder).mode == projects.VIRTUAL_LAB
    assert not page.state.real_cell and page.state.hardware.robot_connection is not None
    assert not is_real(page.state.hardware.robot_connection)
    assert "Cell: the virtual lab" in page.project_details.text() and page.robot_panel.virtual_radio.isEnabled()

    assert page.change_cell((projects.HARDWARE, {"kind": "teach"}, None))
    assert page.state.project.teach_mode and page.state.hardware.robot_connection is None
    assert "teach mode" in page.state.cell and "cameras 0 and 1" in page.state.cell


def test_a_project_made_with_a_folder_and_no_cell_is_a_virtual_lab(page, tmp_path):
    project = project_actions.new_project(page, page.state, tmp_path / "lab")
    assert project.mode == projects.VIRTUAL_LAB and page.state.cell.startswith("the virtual lab")
