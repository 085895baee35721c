"""The Setup page's hardware choice is kept in the project: a serial robot (over the controller
simulator on a real pty) and two image folders as cameras are recorded in project.json, a
reopened project fills the fields again, and cameras plugged the other way round are noticed."""
from __future__ import annotations

import json

import cv2
import numpy as np
import pytest

from app import messages
from app.pages.setup.page import SetupPage
from app.state import WizardState
from app.worker import TaskRunner
from core.project import HARDWARE
from core.robot.controller_sim import ControllerSim
from core.robot.file import read_robot
from core.robot.model import robot_path


@pytest.fixture
def make_page(qtbot):
    made = []

    def make():
        state, tasks = WizardState(), TaskRunner()
        p = SetupPage(state, tasks)
        qtbot.addWidget(p)
        p.resize(1200, 1000)
        p.show()
        made.append((p, state, tasks))
        return p

    yield make
    for p, state, tasks in made:
        p.on_leave()
        tasks.shutdown()
        state.close()


def folder(path, level):
    path.mkdir()
    for i in range(2):
        cv2.imwrite(str(path / f"img_{i}.png"), np.full((48, 64), level + i, np.uint8))
    return path


def open_cameras(page, qtbot, left, right):
    panel = page.camera_panel
    panel.left_edit.setText(str(left))
    panel.right_edit.setText(str(right))
    assert panel.open_cameras()
    qtbot.waitUntil(lambda: page.state.hardware.cameras is not None and not page.task.busy, timeout=10000)


def test_the_hardware_choice_is_restored_and_a_swapped_cable_noticed(make_page, qtbot, tmp_path):
    a, b = folder(tmp_path / "cam_a", 10), folder(tmp_path / "cam_b", 90)
    page = make_page()
    page.state.new_project(tmp_path / "project", mode=HARDWARE)
    page.state.choose_preset("educational_6r")
    messages.set_non_interactive(True)
    try:
        with ControllerSim(read_robot(robot_path("educational_6r")), protocol="grbl", time_scale=0.05) as sim:
            robot = page.robot_panel
            robot.port_edit.setText(sim.port)
            robot.profile_combo.setCurrentText("grbl_joint_arm")
            robot.baud_combo.setCurrentText("57600")
            robot.speed_spin.setValue(40)
            assert robot.connect_robot()
            qtbot.waitUntil(lambda: page.state.hardware.real_robot and not page.task.busy, timeout=10000)
    finally:
        messages.set_non_interactive(False)
    page.camera_panel.settings_form.width_spin.setValue(1280)
    open_cameras(page, qtbot, a, b)
    assert page.state.hardware.camera_changes == [] and "✓ Cameras open." in page.status.text()

    saved = json.loads((tmp_path / "project" / "project.json").read_text())
    assert saved["robot_connection"] == {"kind": "serial", "port": sim.port, "profile": "grbl_joint_arm",
                                         "joint_map": "", "baud": 57600, "speed": 40.0}
    cams = saved["cameras"]
    assert (cams["left"], cams["right"], cams["settings"]["width"]) == (str(a), str(b), 1280)
    assert cams["identity"] == {"left": {"name": "cam_a", "bus": str(a.resolve())},
                                "right": {"name": "cam_b", "bus": str(b.resolve())}}

    again = make_page()
    again.state.open_project(tmp_path / "project")
    robot = again.robot_panel
    assert robot.serial_radio.isChecked() and robot.port_edit.text() == sim.port
    assert robot.profile_combo.currentText() == "grbl_joint_arm" and robot.baud_combo.currentText() == "57600"
    assert robot.speed_spin.value() == 40 and not again.state.hardware.real_robot          # not connected by itself
    cams = again.camera_panel
    assert cams.sources_radio.isChecked() and cams.left_edit.text() == str(a) and cams.right_edit.text() == str(b)
    assert cams.settings_form.width_spin.value() == 1280 and not cams.settings_form.autofocus_check.isChecked()

    open_cameras(again, qtbot, b, a)                                              # cables exchanged
    assert again.state.hardware.camera_changes == ["the left and right cameras are swapped (cables exchanged)"]
    assert "swapped" in again.status.text() and "swapped" in cams.status_label.text()
    again.grab().save(str(tmp_path / "setup_swapped.png"))


def test_a_project_file_with_a_bad_hardware_section_is_one_clear_message(tmp_path):
    from core.errors import RoboCalError
    from core.project import create_project, open_project
    project = create_project(tmp_path / "p")
    data = json.loads(project.file.read_text())
    data["cameras"] = "left"
    project.file.write_text(json.dumps(data))
    with pytest.raises(RoboCalError) as info:
        open_project(project.folder)
    assert info.value.field == "cameras" and "project.json" in info.value.message
