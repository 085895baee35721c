"""Teach mode of the Check page, for a real cell whose robot RoboCal does not drive: the next
check pose is shown, the technician brings the robot there and types the joints it reached (or,
with a controller connected that reports them, leaves the field empty and they are read), and
Record pose captures and locates (app.jobs.cell_teach, on a worker). Once every pose is recorded
the page checks the recorded poses (app.pages.check.runs).

A helper the page holds (`TeachPoses`), with its own state: the poses recorded for the current
check poses (forgotten when other check poses are chosen or the calibration changes).
"""
from __future__ import annotations

from typing import Callable

from app.jobs import cell_teach
from app.jobs.cell_measure import locator
from app.jobs.measurement_hardware import typed_joints
from app.pages.check.inputs import CheckInputs
from app.pages.check.model import CheckModel, CheckOutcome
from app.pages.check.teach_panel import TeachCheckPanel
from app.pages.page_task import PageTask
from core.errors import RoboCalError


class TeachPoses:
    """Check poses recorded one by one by hand (`can_run()`: the page may measure now, else it
    said why; `on_recorded()`: a pose was recorded, the page redraws its controls)."""

    def __init__(self, state, model: CheckModel, panel: TeachCheckPanel, inputs: CheckInputs, task: PageTask, *,
                 set_status: Callable, can_run: Callable[[], bool], on_recorded: Callable[[], None]):
        self.state = state
        self.model = model
        self.panel = panel
        self.inputs = inputs
        self.task = task
        self._set_status = set_status
        self._can_run = can_run
        self._on_recorded = on_recorded
        self.taught: dict[int, cell_teach.TaughtCheckPose] = {}     # check pose -> recorded
        self._cell = None                                           # the check poses they were recorded at
        model.on("poses", self._poses_chosen)
        model.on("cleared", lambda _: self.forget())

    def forget(self) -> None:
        self.taught = {}

    def _poses_chosen(self, outcome: CheckOutcome) -> None:
        if outcome.cell is not self._cell:
            self.forget()
        self._cell = outcome.cell

    def next_pose(self) -> int | None:
        """The first check pose not recorded yet (None: every one, or no check poses)."""
        cell = self.model.result.cell
        if cell is None:
            return None
        return next((k for k in range(len(cell.Q)) if k not in self.taught), None)

    def show_next(self) -> None:
        cell, k = self.model.result.cell, self.next_pose()
        if cell is None:
            self.panel.next_label.setText("Choose the check poses first (Choose check poses).")
        else:
            self.panel.show_next(k, cell.model.q_to_file(cell.Q[k]) if k is not None else None,
                                 len(self.taught), len(cell.Q))
        self.panel.record_button.setEnabled(k is not None and not self.task.busy)
        self.panel.check_button.setEnabled(cell is not None and k is None and not self.task.busy)

    def record_pose(self) -> bool:
        """Record the next check pose where the technician put the robot."""
        if not self._can_run():
            return False
        k = self.next_pose()
        if k is None:
            self._set_status("Choose the check poses first, or check the recorded ones.", False)
            return False
        cell, typed = self.model.result.cell, self.panel.joints_edit.text()
        driver = self._joint_reader()
        q_file = None
        if driver is None or typed.strip():
            try:
                q_file = typed_joints(typed, cell.model)
            except RoboCalError as exc:
                self._set_status(f"Pose {k} not recorded: {exc.message}. {exc.hint or ''}".strip(), False)
                return False
            driver = None
        trained, rect = self.inputs.images()
        return self.task.start(cell_teach.record_check_pose, cell, k, self.state.hardware.cameras,
                               locator(trained, rect), q_typed_file=q_file, driver=driver,
                               on_done=self._recorded, status=f"Recording check pose {k}…")

    def _joint_reader(self):
        """A connected controller whose joints can be read (they are read when none are typed)."""
        driver = self.state.hardware.robot_connection
        if driver is None or not driver.connected or getattr(driver, "lost", None):
            return None
        return driver

    def _recorded(self, taught: cell_teach.TaughtCheckPose) -> None:
        self.taught[taught.index] = taught
        self.panel.joints_edit.clear()
        found = "marker located" if taught.point is not None else "the marker was NOT found (it will count as missing)"
        notes = ("; " + "; ".join(taught.warnings)) if taught.warnings else ""
        self._set_status(f"✓ Pose {taught.index} recorded: {found}{notes}.", taught.point is not None)
        self._on_recorded()
