"""New project… in a folder typed by name: Qt's real (non-native) folder dialog is driven with
keys, a new folder's name is accepted and the project is created in it; an existing empty
folder is still accepted; Cancel makes nothing."""
from __future__ import annotations

import json

import pytest
from PySide6.QtCore import Qt, QTimer
from PySide6.QtWidgets import QApplication, QLineEdit

from app import project_actions
from app.new_folder_dialog import NewFolderDialog, ask_new_folder
from app.pages.setup.page import SetupPage
from app.state import WizardState
from app.worker import TaskRunner
from core import project as projects


@pytest.fixture
def page(qtbot):
    state, tasks = WizardState(), TaskRunner()
    p = SetupPage(state, tasks)
    qtbot.addWidget(p)
    p.show()
    yield p
    p.on_leave()
    tasks.shutdown()
    state.close()


def _answer_folder_dialog(qtbot, text: str | None, seen: list) -> None:
    """Once the folder dialog is open: type `text` into its name field and click its Choose
    button (None: press Esc)."""
    def answer():
        dialog = QApplication.activeModalWidget()
        if not isinstance(dialog, NewFolderDialog):
            QTimer.singleShot(50, answer)
            return
        seen.append(dialog.windowTitle())
        edit = dialog.findChild(QLineEdit, "fileNameEdit")
        if text is None:
            qtbot.keyClick(edit, Qt.Key.Key_Escape)
            return
        edit.clear()
        qtbot.keyClicks(edit, text)
        button = dialog.accept_button()
        seen.append(button.isEnabled())
        if button.isEnabled():
            qtbot.mouseClick(button, Qt.MouseButton.LeftButton)
        else:                                        # fail, not hang
            dialog.reject()
    QTimer.singleShot(0, answer)


def test_a_new_folder_typed_by_name_becomes_the_project(page, qtbot, tmp_path, monkeypatch):
    _start_in(monkeypatch, tmp_path)
    monkeypatch.setattr(project_actions, "ask_cell", lambda parent: (projects.VIRTUAL_LAB, None, None))
    seen: list = []
    _answer_folder_dialog(qtbot, "Cell 7 calibration", seen)
    project = page.new_project()
    target = tmp_path / "Cell 7 calibration"
    assert "type a new folder's name" in seen[0] and seen[1] is True        # Choose is enabled for a new name
    assert project is not None and project.folder == target
    assert json.loads((target / "project.json").read_text())["name"] == "Cell 7 calibration"
    assert page.state.project is project and "Cell 7 calibration" in page.project_folder.text()


def test_an_existing_empty_folder_is_still_accepted(page, qtbot, tmp_path, monkeypatch):
    (tmp_path / "empty").mkdir()
    _start_in(monkeypatch, tmp_path)
    monkeypatch.setattr(project_actions, "ask_cell", lambda parent: (projects.VIRTUAL_LAB, None, None))
    _answer_folder_dialog(qtbot, "empty", [])
    project = page.new_project()
    assert project is not None and project.folder == tmp_path / "empty"
    assert (tmp_path / "empty" / "project.json").is_file()


def test_cancel_makes_no_folder_and_no_project(page, qtbot, tmp_path, monkeypatch):
    _start_in(monkeypatch, tmp_path)
    _answer_folder_dialog(qtbot, None, [])
    assert page.new_project() is None
    assert page.state.project is None and list(tmp_path.iterdir()) == []


def _start_in(monkeypatch, folder) -> None:
    """The real dialog, opened in `folder` instead of the home folder."""
    monkeypatch.setattr(project_actions, "ask_new_folder", lambda parent, title: ask_new_folder(parent, title, folder))
