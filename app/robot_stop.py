"""Stop and Resume of the robot in the window: Stop is always one key away (Esc or Ctrl+.,
whatever has the focus, also in dialogs and menus), a red Stop button while a real robot is
connected, Resume once the technician checked that the way is clear."""
from __future__ import annotations

from PySide6.QtCore import QObject, Qt
from PySide6.QtGui import QAction, QKeySequence
from PySide6.QtWidgets import QMainWindow, QPushButton, QStyle

from app.messages import show_error
from app.state import WizardState
from app.stop_key_filter import StopKeyElsewhere
from app.window_status_bar import WindowStatusBar
from app.worker import TaskRunner
from core.errors import RoboCalError


class RobotStop(QObject):
    """`action_stop` (Esc, Ctrl+.; the window's shortcut, and `StopKeyElsewhere` in other
    windows), `action_resume`, and the nav row's `stop_button` (shown while a real robot is
    connected) and `resume_button` (shown while the robot is stopped). Stop cancels the running
    tasks too. `shut_down()` when the window closes."""

    def __init__(self, window: QMainWindow, state: WizardState, tasks: TaskRunner, status: WindowStatusBar):
        super().__init__(window)
        self.window = window
        self.state = state
        self.tasks = tasks
        self.status = status
        self.action_stop = QAction(window.style().standardIcon(QStyle.StandardPixmap.SP_BrowserStop),
                                   "&Stop robot", window)
        self.action_stop.setShortcuts([QKeySequence(Qt.Key.Key_Escape), QKeySequence("Ctrl+.")])
        self.action_stop.setShortcutContext(Qt.ShortcutContext.WindowShortcut)   # other windows: StopKeyElsewhere
        self.action_stop.setToolTip("Stop the robot now and cancel the running task (Esc or Ctrl+.; in a dialog, "
                                    "Ctrl+., and Esc while the robot moves)")
        self.action_stop.triggered.connect(self.stop)
        self.action_resume = QAction("&Resume after stop", window)
        self.action_resume.triggered.connect(self.resume)
        # a real robot connected: Stop is a big red button on every page (and Esc)
        self.stop_button = QPushButton("■  Stop robot (Esc)")
        self.stop_button.setObjectName("stopRobotButton")
        self.stop_button.setStyleSheet("QPushButton { color: white; background: #c5221f; font-weight: 600; "
                                       "padding: 4px 14px; }")
        self.stop_button.setToolTip("Stop the robot now and cancel the running task (Esc or Ctrl+.)")
        self.stop_button.clicked.connect(self.stop)
        self.resume_button = QPushButton("Resume robot")
        self.resume_button.setObjectName("resumeRobotButton")
        self.resume_button.setToolTip("Accept motion again after a stop, once the way is clear")
        self.resume_button.clicked.connect(self.resume)
        self.keys_elsewhere = StopKeyElsewhere(window, self.motion_running, self.stop)
        self.keys_elsewhere.install()
        for changed in (state.robotChanged, state.hardware.connectionChanged, state.hardware.stoppedChanged):
            changed.connect(self.show_buttons)

    def motion_running(self) -> bool:
        """A robot is connected and ready, and a task runs that may be moving it."""
        conn = self.state.hardware.robot_connection
        return conn is not None and not conn.stopped and self.tasks.busy

    def stop(self) -> None:
        """Stop the robot (if any) and cancel the running tasks: one key, always."""
        stopped = self.state.hardware.stop_robot()
        busy = self.tasks.busy
        self.tasks.cancel_all()
        if stopped:
            self.status.show_message("Robot stopped. Robot ▸ Resume after stop when the way is clear.")
        elif busy:
            self.status.show_message("Stop: the running task was cancelled (no robot connected).", 5000)
        else:
            self.status.show_message("Stop: no robot connected.", 3000)
        self.show_state()

    def resume(self) -> None:
        """Accept motion again after a stop (the technician checked that the way is clear)."""
        try:
            if self.state.hardware.resume_robot():
                self.status.show_message("Robot ready.", 3000)
        except RoboCalError as exc:
            show_error(self.window, f"The robot cannot resume: {exc.message}", "RoboCal: robot")
        self.show_state()

    def show_state(self) -> None:
        """The status bar's robot and the Stop and Resume buttons as the robot is now."""
        self.status.show_mode()
        self.show_buttons()

    def show_buttons(self, *_) -> None:
        conn = self.state.hardware.robot_connection
        self.stop_button.setVisible(self.state.hardware.real_robot)
        self.resume_button.setVisible(conn is not None and conn.stopped)

    def shut_down(self) -> None:
        """The Stop keys no longer watched in other windows, the robot stopped."""
        self.keys_elsewhere.remove()
        self.state.hardware.stop_robot()
