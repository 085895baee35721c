"""The wizard shell with a real robot connection (the controller simulator on a pty): the red
Stop button shows on every page, Esc sends STOP at once from the GUI thread, motion stays
refused until Resume."""
from __future__ import annotations

import pytest
from PySide6.QtCore import Qt
from PySide6.QtWidgets import QApplication

from app.hardware import RobotChoice, open_serial_robot
from app.pages.steps import Step
from core.errors import RoboCalError
from core.robot.controller_sim import ControllerSim
from tests.app.windows import window_on_project


@pytest.fixture
def window(qtbot, tmp_path):
    win = window_on_project(qtbot, tmp_path / "project")
    yield win
    win.close()


def test_stop_button_and_esc_stop_a_serial_robot_until_resume(window, qtbot):
    win = window
    assert not win.stop_button.isVisible()                       # the simulated robot: Esc only
    with ControllerSim(win.state.robot, time_scale=0.05) as sim:
        choice = RobotChoice("serial", sim.port)
        win.state.hardware.use_serial_robot(open_serial_robot(win.state.robot, choice), choice)
        driver = win.state.hardware.robot_connection
        for step in (Step.SETUP, Step.MARKER, Step.MEASUREMENT):
            win.go_to(step)
            assert win.stop_button.isVisible() and not win.resume_button.isVisible()
        assert sim.port in win.mode_label.text()
        win.activateWindow()
        qtbot.waitUntil(lambda: QApplication.activeWindow() is win, timeout=5000)
        qtbot.keyClick(win, Qt.Key.Key_Escape)
        assert driver.stopped and "STOP" in sim.received
        assert win.resume_button.isVisible() and "stopped" in win.mode_label.text()
        with pytest.raises(RoboCalError, match="stopped"):
            driver.move_to(driver.current_joints())
        assert not any(line.startswith("MOVE") for line in sim.received)
        qtbot.mouseClick(win.resume_button, Qt.MouseButton.LeftButton)
        assert not driver.stopped and not win.resume_button.isVisible()
        driver.move_to(driver.current_joints())
        assert sum(line.startswith("MOVE") for line in sim.received) == 1
        qtbot.mouseClick(win.stop_button, Qt.MouseButton.LeftButton)
        assert driver.stopped and sim.received.count("STOP") == 2
        win.state.hardware.use_virtual_robot()
        assert not win.stop_button.isVisible() and not driver.connected
