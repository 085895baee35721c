"""Teach mode of the Check page, for a real cell whose robot RoboCal does not drive: the next
check pose is shown, the technician brings the robot there and types the joints it reached (or,
with a controller connected that reports them, leaves the field empty and they are read),
Record pose captures and locates (app.jobs.cell_teach, on a worker), and once every pose is
recorded the check of the recorded poses is judged and logged.

A mixin of CheckPage (before WizardPage): it uses the page's `state`, `cell`, `teach`
(TeachCheckPanel), `images()`, `cell_words()`, `_can_run()`, `_key()` and `_checked`.
"""
from __future__ import annotations

from app.jobs import cell_teach
from app.jobs.cell_measure import locator
from app.jobs.measurement_hardware import typed_joints
from core.errors import RoboCalError


class TeachMixin:
    """Check poses recorded one by one by hand."""

    def _next_pose(self) -> int | None:
        if self.cell is None:
            return None
        return next((k for k in range(len(self.cell.Q)) if k not in self.taught), None)

    def _show_next_pose(self) -> None:
        k = self._next_pose()
        if self.cell is None:
            self.teach.next_label.setText("Choose the check poses first (Choose check poses).")
        else:
            self.teach.show_next(k, self.cell.model.q_to_file(self.cell.Q[k]) if k is not None else None,
                                 len(self.taught), len(self.cell.Q))
        self.teach.record_button.setEnabled(k is not None and not self.task.busy)
        self.teach.check_button.setEnabled(self.cell is not None and k is None and not self.task.busy)

    def record_pose(self) -> bool:
        """Teach mode: record the next check pose where the technician put the robot."""
        if not self._can_run():
            return False
        k = self._next_pose()
        if k is None:
            self._set_status("Choose the check poses first, or check the recorded ones.", False)
            return False
        driver = self._joint_reader()
        q_file = None
        if driver is None or self.teach.joints_edit.text().strip():
            try:
                q_file = typed_joints(self.teach.joints_edit.text(), self.cell.model)
            except RoboCalError as exc:
                self._set_status(f"Pose {k} not recorded: {exc.message}. {exc.hint or ''}".strip(), False)
                return False
            driver = None
        trained, rect = self.images()
        self._where = self.cell_words()
        return self.task.start(cell_teach.record_check_pose, self.cell, k, self.state.hardware.cameras, locator(trained, rect),
                          q_typed_file=q_file, driver=driver, on_done=self._pose_recorded,
                          status=f"Recording check pose {k}…")

    def _joint_reader(self):
        """A connected controller whose joints can be read (they are read when none are typed)."""
        driver = self.state.hardware.robot_connection
        if driver is None or not driver.connected or getattr(driver, "lost", None):
            return None
        return driver

    def _pose_recorded(self, taught: cell_teach.TaughtCheckPose) -> None:
        self.taught[taught.index] = taught
        self.teach.joints_edit.clear()
        found = "marker located" if taught.point is not None else "the marker was NOT found (it will count as missing)"
        notes = ("; " + "; ".join(taught.warnings)) if taught.warnings else ""
        self._set_status(f"✓ Pose {taught.index} recorded: {found}{notes}.", taught.point is not None)
        self.on_busy_changed()

    def _check_taught(self) -> bool:
        if self._next_pose() is not None:
            self._set_status(f"Record every check pose first: {len(self.taught)} of {len(self.cell.Q)} recorded.",
                             False)
            return False
        key = self._key()
        self._where = self.cell_words()
        self._measure = None
        return self.task.start(cell_teach.check_taught, self.cell, list(self.taught.values()), log=self.log_path(),
                          on_done=lambda value: self._checked_taught(value, key),
                          status=f"Checking the recorded poses, {self._where}…")

    def _checked_taught(self, value, key: tuple) -> None:
        self.taught = {}
        self._checked((self.cell, *value), key)
