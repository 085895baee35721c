"""Quitting a demo that has results asks first and can keep them as a project."""
from __future__ import annotations

from PySide6.QtCore import QTimer
from PySide6.QtWidgets import QApplication, QMessageBox

from app import messages, project_actions
from app.main_window import MainWindow
from app.state import WizardState


def _demo_window(qtbot, results: bool):
    state = WizardState()
    project = state.temporary_project()
    state.choose_preset("educational_6r")
    if results:
        (project.folder / "stereo.yaml").write_text("%YAML:1.0\n---\nimage_width: 640\n")
        (project.folder / "checkerboard" / "left").mkdir(parents=True)
    win = MainWindow(state)
    qtbot.addWidget(win)
    win.show()
    qtbot.waitExposed(win)
    return win, project.folder


def _answer_with(text: str) -> None:
    """Click the button `text` of the question box as soon as it is shown."""
    def click():
        box = QApplication.activeModalWidget()
        if not isinstance(box, QMessageBox):
            QTimer.singleShot(20, click)
            return
        button = next(b for b in box.buttons() if b.text() == text)
        button.click()
    QTimer.singleShot(20, click)


def test_a_demo_without_results_quits_without_asking(qtbot):
    win, folder = _demo_window(qtbot, results=False)
    assert win.action_save_demo.isVisible()
    assert win.close()
    assert not folder.exists()


def test_cancel_keeps_the_window_and_the_demo(qtbot):
    win, folder = _demo_window(qtbot, results=True)
    _answer_with("Cancel")
    assert not win.close()
    assert win.isVisible() and (folder / "stereo.yaml").is_file()
    _answer_with("Quit without saving")
    assert win.close()
    assert not folder.exists()


def test_save_the_demo_as_a_project_then_quit(qtbot, tmp_path, monkeypatch):
    win, folder = _demo_window(qtbot, results=True)
    target = tmp_path / "my-demo"
    monkeypatch.setattr(project_actions, "ask_new_folder", lambda *a, **k: target)
    _answer_with("Save the demo as a project…")
    assert win.close()
    assert not folder.exists()
    assert (target / "project.json").is_file() and (target / "robot.json").is_file()
    assert (target / "stereo.yaml").read_text().startswith("%YAML:1.0")
    assert (target / "checkerboard" / "left").is_dir()


def test_a_non_empty_folder_is_refused_and_nothing_is_lost(qtbot, tmp_path, monkeypatch):
    win, folder = _demo_window(qtbot, results=True)
    target = tmp_path / "busy"
    target.mkdir()
    (target / "thesis.tex").write_text("keep me")
    monkeypatch.setattr(project_actions, "ask_new_folder", lambda *a, **k: target)
    _answer_with("Save the demo as a project…")
    QTimer.singleShot(400, lambda: _answer_with("OK"))          # the refusal's message box
    assert not win.close()
    assert (folder / "stereo.yaml").is_file() and sorted(p.name for p in target.iterdir()) == ["thesis.tex"]
    assert win.windowTitle().endswith("(temporary demo)")
    _answer_with("Quit without saving")
    assert win.close()


def test_the_autopilot_quits_without_asking(qtbot):
    win, folder = _demo_window(qtbot, results=True)
    messages.set_non_interactive(True)
    try:
        assert win.close()
    finally:
        messages.set_non_interactive(False)
    assert not folder.exists()
