""""Check every N min" on the Check page: a timer that runs a check on each tick unless a task
runs, following the schedule chosen in the options, and why checks cannot run on a schedule
(then the controls switch a running schedule off).

A helper the page holds (`CheckSchedule`), with its own state: the timer and the minutes it runs at.
"""
from __future__ import annotations

from typing import Callable

from PySide6.QtCore import QTimer

from app.pages.check.controls_panel import CheckControls
from app.pages.check.inputs import CheckInputs
from app.pages.check.model import CheckModel, CheckOptions
from app.pages.page_task import PageTask


class CheckSchedule:
    """`run()` starts a check; `problem()`: why the real cell cannot measure now (None: it can)."""

    def __init__(self, parent, model: CheckModel, controls: CheckControls, inputs: CheckInputs, task: PageTask, *,
                 run: Callable[[], bool], problem: Callable[[], str | None]):
        self.controls = controls
        self.inputs = inputs
        self.task = task
        self._run = run
        self._problem = problem
        self._minutes: int | None = None
        self.timer = QTimer(parent)
        self.timer.timeout.connect(self.tick)
        model.on("options", self._options_changed)

    def _options_changed(self, options: CheckOptions) -> None:
        if options.schedule_minutes == self._minutes:
            return
        self._minutes = options.schedule_minutes
        if self._minutes is None:
            self.timer.stop()
        else:
            self.timer.start(self._minutes * 60_000)

    def tick(self) -> None:
        """The timer's tick: a check, unless a task runs."""
        if not self.task.busy:
            self._run()

    def switch_off(self) -> bool:
        """Switch the schedule off; whether it was on."""
        was_on = self.controls.schedule_check.isChecked()
        self.controls.schedule_check.setChecked(False)
        return was_on

    def blocked(self) -> str | None:
        """Why checks cannot run on a schedule here (None: they can)."""
        state = self.inputs.state
        if state.project is None:
            return "there is no project: choose one on the Setup page"
        if not self.inputs.ready():
            return "the project has no calibrated robot (calibrated.json): run the Identification step first"
        if self.inputs.teach_mode:
            return "in teach mode the robot is brought to every check pose by hand"
        if not state.virtual:
            problem = self._problem()
            if problem is not None:
                return f"nothing can be measured: {problem}"
        return None
