"""The wizard shell: every page visited offscreen, screenshots, explain panel, Stop key."""
from __future__ import annotations

import numpy as np
import pytest
from PySide6.QtCore import Qt
from PySide6.QtGui import QImage, QKeySequence
from PySide6.QtWidgets import QApplication

from app.main_window import MainWindow
from app.pages import registry
from app.pages.base import WizardPage
from app.pages.steps import STEP_INFO, Step
from app.state import WizardState
from tests.app.windows import modal_dialog
from widgets.step_list import StepState

HELP_PHRASES = {
    Step.SETUP: "Rz(θ", Step.STEREO: "k1r²", Step.MARKER: "SSD(d)", Step.POSES: "κ = σ1 / σm",
    Step.MEASUREMENT: "Z = f · b / d", Step.IDENTIFICATION: "Δg = (ΦTΦ)−1 ΦT ΔX",
    Step.EXPORT: "URDF", Step.CHECK: "Ce(q) = J(q)", Step.COMPENSATION: "Δx = Jg · Δg",
}


@pytest.fixture
def fresh_window(qtbot):
    """A new wizard window, shown, for a test that changes it (a project, the robot, closing)."""
    win = MainWindow(WizardState())
    qtbot.addWidget(win)
    win.resize(1400, 900)
    win.show()
    qtbot.waitExposed(win)
    yield win
    win.close()


@pytest.fixture(scope="module")
def hidden_window(qapp):
    """One wizard window (no project) for the tests that only look at it, move between its pages
    or run a task in it and wait for its end (building one takes ~2 s of CPU: every page with its
    plots). Built when the first of them (test_nine_steps_in_order) asks for it; hidden between
    tests (see `window`)."""
    win = MainWindow(WizardState())
    win.resize(1400, 900)
    yield win
    win.show()
    win.close()
    win.deleteLater()
    QApplication.processEvents()


@pytest.fixture
def window(hidden_window, qtbot):
    """The module's window, shown for one test, then back on step 1 and hidden. Each test that
    uses it leaves it as it found it (checked here): no project, no task running, the explain
    panel shown."""
    win = hidden_window
    win.show()
    qtbot.waitExposed(win)
    yield win
    qtbot.waitUntil(lambda: not win.tasks.busy, timeout=10000)
    assert win.state.project is None and win.explain_dock.isVisible()
    win.go_to(Step.SETUP)
    win.hide()


@pytest.fixture
def ready_window(fresh_window, tmp_path):
    fresh_window.state.new_project(tmp_path / "project")
    fresh_window.state.choose_preset("educational_6r")
    return fresh_window


def image_stats(image: QImage) -> tuple[int, float]:
    image = image.convertToFormat(QImage.Format.Format_RGB32)
    data = np.frombuffer(image.constBits(), np.uint8, count=image.sizeInBytes())
    data = data.reshape(image.height(), image.bytesPerLine())[:, : image.width() * 4]
    pixels = np.ascontiguousarray(data).reshape(-1, 4)[::7]
    return len(np.unique(pixels.copy().view(np.uint32))), float(data.std())      # a pixel's 4 bytes as one number


def test_nine_steps_in_order(window):
    assert [p.step for p in window.pages] == list(Step)
    assert [window.step_list.item(i).text().split("\n")[0] for i in range(9)] == [
        "1. Setup", "2. Stereo calibration", "3. Marker", "4. Pose sequence", "5. Measurement",
        "6. Identification", "7. Export", "8. Check", "9. Compensation"]
    assert all(isinstance(p, WizardPage) and p.load_error is None for p in window.pages)
    assert window.current_step is Step.SETUP and window.page(Step.SETUP).load_error is None


def test_visit_every_page_from_the_side_list_with_screenshots(window, qtbot, tmp_path):
    for step in reversed(list(Step)):        # any order works, not only forwards
        window.step_list.setCurrentRow(int(step))
        assert window.current_step is step
        assert window.stack.currentWidget().widget().page is window.page(step)
        assert window.page_title.text() == f"{step.number}. {STEP_INFO[step].title}"
        QApplication.processEvents()
        path = window.save_screenshot(tmp_path / f"{step.number:02d}-{step.slug}.png")
        image = QImage(str(path))
        assert not image.isNull() and image.width() >= 1000 and image.height() >= 600
        colours, spread = image_stats(image)
        assert colours > 20 and spread > 5, f"{path.name} looks uniform"


def test_explain_panel_shows_each_pages_help(window):
    for step in Step:
        window.go_to(step)
        text = window.explain.plain_text()
        assert window.explain.current_file.name == f"{step.slug}.html"
        assert window.explain.current_file.is_file()
        assert "What to look for" in text
        assert HELP_PHRASES[step].replace(" ", "") in text.replace(" ", "").replace("\u2009", ""), step
        assert window.explain_dock.windowTitle() == f"Explain: {STEP_INFO[step].title}"


def test_explain_panel_can_be_hidden_and_shown(window):
    assert window.explain_dock.isVisible() and window.action_explain.isChecked()
    window.action_explain.trigger()
    assert not window.explain_dock.isVisible() and not window.action_explain.isChecked()
    window.action_explain.trigger()
    assert window.explain_dock.isVisible()
    assert window.action_explain.shortcut() == QKeySequence(Qt.Key.Key_F1)


def test_each_step_has_its_own_page(window):
    for step in Step:
        page = window.page(step)
        window.go_to(step)
        assert page.load_error is None and type(page) is registry.PAGES[step], step
        assert window.step_list.state(int(step)) is not StepState.ERROR


def test_next_is_gated_by_the_setup_page(fresh_window, tmp_path):
    assert not fresh_window.next_button.isEnabled() and not fresh_window.back_button.isEnabled()
    assert fresh_window.step_list.state(0) is StepState.TODO
    fresh_window.next()
    assert fresh_window.current_step is Step.SETUP
    fresh_window.state.choose_preset("ur5")
    assert not fresh_window.next_button.isEnabled()          # still no project
    fresh_window.state.new_project(tmp_path / "p")
    assert fresh_window.next_button.isEnabled()
    assert fresh_window.step_list.state(0) is StepState.DONE
    assert (tmp_path / "p" / "robot.json").is_file()   # the robot chosen first went into it


def test_next_waits_for_each_page_and_back_walks_all_pages(ready_window, qtbot):
    win = ready_window
    last = list(Step)[-1]
    for step in list(Step)[1:]:
        win.step_list.setCurrentRow(int(step))          # the side list reaches every page
        assert win.current_step is step
        page = win.page(step)
        may_leave = step is not last and page.is_complete()
        assert win.next_button.isEnabled() == may_leave, step
        if may_leave:
            qtbot.mouseClick(win.next_button, Qt.MouseButton.LeftButton)
            assert win.current_step == step + 1
    win.go_to(last)
    assert not win.next_button.isEnabled()             # last page
    for step in reversed(list(Step)[:-1]):
        qtbot.mouseClick(win.back_button, Qt.MouseButton.LeftButton)
        assert win.current_step is step
        assert win.step_list.currentRow() == int(step)
    assert not win.back_button.isEnabled()


def test_stop_key_stops_the_robot(ready_window, qtbot):
    win = ready_window
    robot = win.state.hardware.robot_connection
    assert robot is not None and robot.connected and not robot.stopped
    keys = [s.toString() for s in win.action_stop.shortcuts()]
    assert keys == ["Esc", "Ctrl+."]
    win.activateWindow()
    qtbot.waitUntil(lambda: QApplication.activeWindow() is win, timeout=5000)
    win.go_to(Step.MEASUREMENT)
    qtbot.keyClick(win, Qt.Key.Key_Escape)
    assert robot.stopped and robot.stop_count == 1
    win.resume_robot()
    assert not robot.stopped
    # from a child widget with focus, and the second shortcut
    win.go_to(Step.SETUP)
    win.page(Step.SETUP).preset_combo.setFocus()
    qtbot.keyClick(win.page(Step.SETUP).dh_table, Qt.Key.Key_Period, Qt.KeyboardModifier.ControlModifier)
    assert robot.stop_count == 2
    assert "stopped" in win.mode_label.text()


def test_stop_cancels_running_tasks(ready_window, qtbot):
    import threading
    started = threading.Event()

    def endless(*, cancelled):
        started.set()
        while not cancelled():
            threading.Event().wait(0.005)
        from core.errors import Cancelled
        raise Cancelled()

    outcome = []
    ready_window.run_task(endless, on_cancelled=lambda: outcome.append("cancelled"), label="Moving")
    assert started.wait(10)
    assert ready_window.progress_bar.isVisible() and ready_window.cancel_button.isVisible()
    ready_window.action_stop.trigger()
    qtbot.waitUntil(lambda: not ready_window.tasks.busy, timeout=10000)
    assert outcome == ["cancelled"] and ready_window.state.hardware.robot_connection.stopped
    assert not ready_window.progress_bar.isVisible()


def test_status_bar_progress_and_cancel_button(window, qtbot):
    import threading
    gate = threading.Event()

    def job(*, progress, cancelled):
        progress(0.5, "half way")
        while not cancelled():
            gate.wait(0.005)
        from core.errors import Cancelled
        raise Cancelled()

    window.run_task(job, label="Calibrating")
    qtbot.waitUntil(lambda: window.progress_bar.value() == 500, timeout=10000)
    assert "Calibrating: half way" in window.progress_bar.format()
    qtbot.mouseClick(window.cancel_button, Qt.MouseButton.LeftButton)
    qtbot.waitUntil(lambda: not window.tasks.busy, timeout=10000)
    assert not window.cancel_button.isVisible()


def test_task_error_without_handler_shows_a_message_box(window, qtbot, monkeypatch):
    from PySide6.QtWidgets import QMessageBox
    shown = []
    monkeypatch.setattr(QMessageBox, "critical", lambda *a, **k: shown.append(a))

    def fails():
        raise RuntimeError("sensor unplugged")

    window.run_task(fails, label="Capturing")
    qtbot.waitUntil(lambda: bool(shown), timeout=10000)
    assert shown[0][1] == "RoboCal: Capturing" and shown[0][2] == "RuntimeError: sensor unplugged"


def test_closing_the_window_cancels_tasks_and_disconnects(ready_window, qtbot):
    import threading
    started = threading.Event()

    def endless(*, cancelled):
        started.set()
        while not cancelled():
            threading.Event().wait(0.005)
        return "stopped"

    ready_window.run_task(endless)
    assert started.wait(10)
    robot = ready_window.state.hardware.robot_connection
    ready_window.close()
    assert not ready_window.tasks.busy
    assert robot.stopped and not robot.connected


def test_a_page_that_fails_to_load_is_shown_not_fatal(qtbot, monkeypatch):
    class BrokenPage(WizardPage):
        step = Step.MARKER

        def __init__(self, *args, **kwargs):
            super().__init__(*args, **kwargs)
            raise ValueError("no marker widgets")

    monkeypatch.setitem(registry.PAGES, Step.MARKER, BrokenPage)
    win = MainWindow(WizardState())
    qtbot.addWidget(win)
    page = win.page(Step.MARKER)
    assert page.load_error == "ValueError: no marker widgets"
    assert "could not be loaded" in page.notice.text()
    assert win.step_list.state(int(Step.MARKER)) is StepState.ERROR
    done = []
    page.autopilot(lambda ok=True, message="": done.append((ok, message)))
    assert done and done[0][0] is False


def test_every_registered_page_is_a_wizard_page_of_its_step():
    for step in Step:
        assert issubclass(registry.PAGES[step], WizardPage) and registry.PAGES[step].step is step


def test_page_registered_for_the_wrong_step_is_refused(qtbot):
    from app.pages.setup.page import SetupPage
    from app.worker import TaskRunner
    state, tasks = WizardState(), TaskRunner()
    with pytest.raises(TypeError, match="registered for STEREO"):
        SetupPage(state, tasks, step=Step.STEREO)


def test_window_title_follows_the_project(fresh_window, tmp_path):
    assert fresh_window.windowTitle() == "RoboCal — no project"
    fresh_window.state.new_project(tmp_path / "Cell 7")
    assert fresh_window.windowTitle() == "RoboCal — Cell 7"


def test_stop_key_works_while_a_modal_dialog_is_open(ready_window, qtbot):
    robot = ready_window.state.hardware.robot_connection
    dialog, field = modal_dialog(ready_window, qtbot)
    qtbot.keyClick(field, Qt.Key.Key_Period, Qt.KeyboardModifier.ControlModifier)
    assert robot.stop_count == 1                      # once, although the key travels up to the dialog
    ready_window.resume_robot()
    qtbot.keyClick(field, Qt.Key.Key_Escape)          # Esc with the robot standing still: only closes the dialog
    assert robot.stop_count == 1 and not robot.stopped
    qtbot.waitUntil(lambda: not dialog.isVisible(), timeout=5000)
    qtbot.keyClick(ready_window, Qt.Key.Key_A)        # other keys do nothing
    assert robot.stop_count == 1
    dialog.deleteLater()


def test_esc_in_a_dialog_stops_a_moving_robot(ready_window, qtbot):
    import threading
    robot = ready_window.state.hardware.robot_connection
    release = threading.Event()
    handle = ready_window.run_task(lambda progress=None, cancelled=None: release.wait(30), label="Moving")
    assert ready_window.motion_running()
    dialog, field = modal_dialog(ready_window, qtbot)
    qtbot.keyClick(field, Qt.Key.Key_Escape)          # while a motion runs, Esc stops it (and closes the dialog)
    assert robot.stopped and robot.stop_count == 1
    release.set()
    qtbot.waitUntil(lambda: not ready_window.tasks.busy, timeout=10000)
    assert handle is not None
    dialog.deleteLater()


def test_stop_key_works_while_a_menu_is_open(ready_window, qtbot):
    robot = ready_window.state.hardware.robot_connection
    menu = ready_window.menuBar().actions()[0].menu()
    menu.popup(ready_window.mapToGlobal(ready_window.rect().center()))
    qtbot.waitUntil(lambda: QApplication.activePopupWidget() is menu, timeout=5000)
    qtbot.keyClick(menu, Qt.Key.Key_Period, Qt.KeyboardModifier.ControlModifier)   # Ctrl+. stops from a menu
    assert robot.stopped and robot.stop_count == 1
    ready_window.resume_robot()
    qtbot.keyClick(menu, Qt.Key.Key_Escape)           # Esc with the robot still: closes the menu only
    assert not robot.stopped and robot.stop_count == 1
    qtbot.waitUntil(lambda: not menu.isVisible(), timeout=5000)
