"""The window's status bar: the running task's progress with its Cancel button (shown while a
task runs), messages, and which cell is in use (the virtual lab or hardware, the robot and
whether it is stopped)."""
from __future__ import annotations

from PySide6.QtCore import QObject
from PySide6.QtWidgets import QLabel, QMainWindow, QProgressBar, QPushButton

from app.state import WizardState
from app.worker import TaskRunner


class WindowStatusBar(QObject):
    """Fills `window`'s status bar: `progress_bar` and `cancel_button` follow `tasks`,
    `mode_label` follows the state's robot and its connection."""

    def __init__(self, window: QMainWindow, state: WizardState, tasks: TaskRunner):
        super().__init__(window)
        self.window = window
        self.state = state
        self.tasks = tasks
        self.bar = window.statusBar()
        self.progress_bar = QProgressBar()
        self.progress_bar.setRange(0, 1000)
        self.progress_bar.setMinimumWidth(240)
        self.progress_bar.setTextVisible(True)
        self.cancel_button = QPushButton("Cancel")
        self.cancel_button.setToolTip("Cancel the running task")
        self.cancel_button.clicked.connect(self.cancel_tasks)
        self.mode_label = QLabel()
        self.mode_label.setObjectName("hint")
        self.bar.addPermanentWidget(self.progress_bar)
        self.bar.addPermanentWidget(self.cancel_button)
        self.bar.addPermanentWidget(self.mode_label)
        self.progress_bar.hide()
        self.cancel_button.hide()
        tasks.progress.connect(self.show_progress)
        tasks.busyChanged.connect(self.show_busy)
        for changed in (state.robotChanged, state.hardware.connectionChanged, state.hardware.stoppedChanged):
            changed.connect(self.show_mode)

    def show_message(self, text: str, timeout_ms: int = 0) -> None:
        """`text` in the status bar for `timeout_ms` (0: until the next message)."""
        self.bar.showMessage(text, timeout_ms)

    def cancel_tasks(self) -> None:
        self.tasks.cancel_all()
        self.progress_bar.setFormat("Cancelling…")

    def show_progress(self, fraction: float, message: str, label: str) -> None:
        """`fraction` (0..1) of the task `label` done, with its `message`."""
        self.progress_bar.setValue(int(round(1000 * min(max(fraction, 0.0), 1.0))))
        text = f"{label}: {message}" if message else label
        self.progress_bar.setFormat(f"{text.replace('%', '%%')}  %p%")
        # wide enough for its words (on one line), up to half the window; the rest in the tooltip
        needed = self.progress_bar.fontMetrics().horizontalAdvance(f"{text}  100%") + 24
        self.progress_bar.setMinimumWidth(max(240, min(needed, self.window.width() // 2)))
        self.progress_bar.setToolTip(text)

    def show_busy(self, busy: bool) -> None:
        self.progress_bar.setVisible(busy)
        self.cancel_button.setVisible(busy)
        if busy:
            self.progress_bar.setValue(0)
        else:
            self.progress_bar.setFormat("%p%")

    def show_mode(self, *_) -> None:
        """The virtual lab or hardware, and the robot: none, ready or stopped (a real robot by name)."""
        conn = self.state.hardware.robot_connection
        mode = "Virtual lab" if self.state.virtual else "Hardware"
        robot = "no robot" if conn is None else ("robot stopped" if conn.stopped else "robot ready")
        if self.state.hardware.real_robot:
            robot = f"{conn.name} · {robot}"
        self.mode_label.setText(f"  {mode} · {robot}  ")
