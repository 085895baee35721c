"""The Stop keys in a dialog or a menu: one key press stops the robot once, however slowly the
press travels from the window to the focus widget and up to the dialog, and two presses in
quick succession stop it twice. Presses are sent both through the window system (to the
dialog's or menu's window, as a real keyboard does) and straight to the focus widget."""
from __future__ import annotations

import time

import pytest
from PySide6.QtCore import Qt
from PySide6.QtTest import QTest
from PySide6.QtWidgets import QApplication, QLineEdit

from tests.app.windows import modal_dialog, window_on_project

CTRL = Qt.KeyboardModifier.ControlModifier

#: longer than a slow controller's stop acknowledgement or a busy GUI thread between two steps
#: of one press (s)
BUSY_S = 0.08


class BusyField(QLineEdit):
    """A text field whose key handling keeps the GUI thread busy for BUSY_S before it passes
    the key on to its dialog."""

    def keyPressEvent(self, event) -> None:
        time.sleep(BUSY_S)
        super().keyPressEvent(event)


@pytest.fixture
def window(qtbot, tmp_path):
    win = window_on_project(qtbot, tmp_path / "project")
    yield win
    win.close()


@pytest.fixture
def busy_dialog(window, qtbot):
    dialog, field = modal_dialog(window, qtbot, BusyField)
    yield dialog, field
    dialog.close()


@pytest.fixture
def open_menu(window, qtbot):
    menu = window.menuBar().actions()[0].menu()
    menu.popup(window.mapToGlobal(window.rect().center()))
    qtbot.waitUntil(lambda: QApplication.activePopupWidget() is menu, timeout=5000)
    yield menu
    menu.close()


def test_each_ctrl_period_in_a_busy_dialog_stops_once(window, busy_dialog):
    robot = window.state.hardware.robot_connection
    dialog, field = busy_dialog
    QTest.keyClick(dialog.windowHandle(), Qt.Key.Key_Period, CTRL)   # window -> field -> dialog
    assert robot.stopped and robot.stop_count == 1
    QTest.keyClick(dialog.windowHandle(), Qt.Key.Key_Period, CTRL)
    assert robot.stop_count == 2
    QTest.keyClick(field, Qt.Key.Key_Period, CTRL)                   # field -> dialog
    QTest.keyClick(field, Qt.Key.Key_Period, CTRL)
    assert robot.stop_count == 4


def test_esc_in_a_busy_dialog_stops_a_moving_robot_once(window, busy_dialog, qtbot):
    import threading
    robot = window.state.hardware.robot_connection
    release = threading.Event()
    window.run_task(lambda progress=None, cancelled=None: release.wait(30), label="Moving")
    assert window.motion_running()
    dialog, _field = busy_dialog
    QTest.keyClick(dialog.windowHandle(), Qt.Key.Key_Escape)
    assert robot.stopped and robot.stop_count == 1
    release.set()
    qtbot.waitUntil(lambda: not window.tasks.busy, timeout=10000)


def test_two_quick_presses_in_a_menu_stop_twice(window, open_menu):
    robot = window.state.hardware.robot_connection
    QTest.keyClick(open_menu, Qt.Key.Key_Period, CTRL)        # back to back, to the same menu
    QTest.keyClick(open_menu, Qt.Key.Key_Period, CTRL)
    assert robot.stop_count == 2
    QTest.keyClick(open_menu.windowHandle(), Qt.Key.Key_Period, CTRL)
    QTest.keyClick(open_menu.windowHandle(), Qt.Key.Key_Period, CTRL)
    assert robot.stop_count == 4
