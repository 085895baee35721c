"""The window's project: New, Open, Save and Save the demo as a project (the File menu and the
toolbar), the project's name in the window's title, and the question before a demo with
results is thrown away."""
from __future__ import annotations

from PySide6.QtCore import QObject
from PySide6.QtGui import QAction, QKeySequence
from PySide6.QtWidgets import QMainWindow, QStyle

from app import project_actions
from app.messages import choose
from app.state import WizardState


class ProjectMenu(QObject):
    """`action_new`, `action_open`, `action_save` (with their standard shortcuts) and
    `action_save_demo` (shown while the project is the temporary demo); the window's title
    follows the project."""

    def __init__(self, window: QMainWindow, state: WizardState):
        super().__init__(window)
        self.window = window
        self.state = state
        icon = window.style().standardIcon
        self.action_new = QAction(icon(QStyle.StandardPixmap.SP_FileIcon), "&New project…", window)
        self.action_new.setShortcut(QKeySequence.StandardKey.New)
        self.action_new.triggered.connect(lambda: project_actions.new_project(window, state))
        self.action_open = QAction(icon(QStyle.StandardPixmap.SP_DirOpenIcon), "&Open project…", window)
        self.action_open.setShortcut(QKeySequence.StandardKey.Open)
        self.action_open.triggered.connect(lambda: project_actions.open_project(window, state))
        self.action_save = QAction(icon(QStyle.StandardPixmap.SP_DialogSaveButton), "&Save", window)
        self.action_save.setShortcut(QKeySequence.StandardKey.Save)
        self.action_save.triggered.connect(self.save)
        self.action_save_demo = QAction("Save the demo as a project…", window)
        self.action_save_demo.triggered.connect(lambda: project_actions.save_demo_as_project(window, state))
        state.projectChanged.connect(self.show_title)

    def save(self) -> bool:
        """Save the project (a message box if it cannot be); True once saved."""
        ok = project_actions.save_project(self.window, self.state)
        if ok:
            self.window.statusBar().showMessage(f"Saved {self.state.project.folder}", 5000)
        return ok

    def show_title(self, *_) -> None:
        """The project's name in the window's title; Save the demo shown for the demo only."""
        project = self.state.project
        name = project.name if project is not None else "no project"
        demo = " (temporary demo)" if self.state.is_temporary() else ""
        self.window.setWindowTitle(f"RoboCal — {name}{demo}")
        self.action_save_demo.setVisible(self.state.is_temporary())

    def demo_may_close(self) -> bool:
        """A demo with results is kept only if saved: ask (False: the user cancelled)."""
        if not project_actions.demo_has_results(self.state):
            return True
        save, discard = "Save the demo as a project…", "Quit without saving"
        answer = choose(self.window, "The demo's images, results, exports and report are in a temporary folder "
                                     "that is deleted when RoboCal quits. Save them as a project first?",
                        [save, discard], "RoboCal: quit", non_interactive_answer=discard)
        if answer == save:
            return project_actions.save_demo_as_project(self.window, self.state) is not None
        return answer == discard
