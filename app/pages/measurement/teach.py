"""Teach mode of the Measurement page, for a robot RoboCal does not move (none connected, or a
controller that only reports its joints), or when the technician chooses it: the page shows
the next pose, the technician brings the robot there with its pendant, and Record pose reads
the joints from the controller (or takes the values typed or pasted from the pendant), checks
them against the joint limits and the plan, captures, locates and writes the pose
(app.jobs.measurement_hardware.record_taught_pose, on a worker).

A mixin of MeasurementPage (after RunMixin, before WizardPage): it uses the page's `rows`,
`poses`, `controls`, `table`, `teach` (TeachPanel), `views` and `_pose_done`.
"""
from __future__ import annotations

from app.jobs.measurement import MEASURED, PENDING, PoseRow
from app.jobs.measurement_hardware import capture_source, off_plan, record_taught_pose, typed_joints
from app.pages.measurement.teach_panel import pose_html
from core.errors import RoboCalError
from core.poses.candidates import arm_polyline


class TeachMixin:
    """Teach mode: forced when RoboCal cannot move the robot, else the technician's choice."""

    _teach_chosen = False

    # -- mode ------------------------------------------------------------------------------
    def _drivable(self) -> bool:
        """RoboCal can move the connected robot."""
        driver = self.state.hardware.robot_connection
        return driver is not None and driver.connected and driver.info.can_move

    def _readable(self):
        """The connected driver when its joints can be read now, else None."""
        driver = self.state.hardware.robot_connection
        if driver is None or not driver.connected or getattr(driver, "lost", None):
            return None
        return driver

    @property
    def teach_mode(self) -> bool:
        forced = not self.state.virtual and not self._drivable()
        return forced or self._teach_chosen

    def _connection_changed(self, *_) -> None:
        """Another robot connection: its joints are read when they can be."""
        self.teach.read_check.setChecked(self._readable() is not None)
        self._update_mode()

    def _teach_toggled(self, on: bool) -> None:
        if self.controls.teach_check.isEnabled():
            self._teach_chosen = bool(on)
        self._update_mode()

    def _update_mode(self) -> None:
        """Teach panel or run views, the Teach mode box, the buttons (`_update_buttons` also
        shows the next pose)."""
        forced = not self.state.virtual and not self._drivable()
        check = self.controls.teach_check
        check.blockSignals(True)
        check.setChecked(self.teach_mode)
        check.setToolTip("RoboCal cannot move this robot: bring it to each pose with its pendant" if forced else
                         "Bring the robot to each pose yourself (pendant or by hand); RoboCal only captures")
        check.blockSignals(False)
        teach = self.teach_mode
        if teach != self.teach.isVisible():
            self.teach.setVisible(teach)
            self.views.setVisible(not teach)
            total = sum(self.splitter.sizes()) or 560
            self.splitter.setSizes([total * 9 // 20, 0, total * 11 // 20] if teach else [total // 2, total // 2, 0])
        self._update_buttons()
        if not self.task.busy and self.poses is not None:
            self._ready_status()

    # -- the next pose ---------------------------------------------------------------------
    def _teach_row(self) -> PoseRow | None:
        """The selected pose when it is not measured yet, else the first pose still to measure."""
        i = self.table.selected()
        if i is not None and 0 <= i < len(self.rows) and self.rows[i].status != MEASURED:
            return self.rows[i]
        return next((r for r in self.rows if r.status == PENDING), None)

    def _show_teach(self) -> None:
        if not self.teach_mode:
            return
        row, model = self._teach_row(), self.state.robot
        if row is None or model is None or self.poses is None:
            self.teach.show_pose("<b>No pose left to record.</b>" if self.rows else "<b>No pose list.</b>", None)
        else:
            left = sum(1 for r in self.rows if r.status != MEASURED)
            arm = arm_polyline(model, self.poses.Q[row.index:row.index + 1])[0][0]
            self.teach.show_pose(pose_html(row.pose, f"{left} of {len(self.rows)} still to measure", model,
                                           self.poses.q_file[row.index]), arm)
        self._typed_changed(self.teach.joints_edit.text())
        self.teach.set_enabled(busy=self.task.busy, can_read=self._readable() is not None, has_pose=row is not None)

    def _typed_changed(self, text: str) -> None:
        """Check the typed values against the limits and the plan as they are typed."""
        row, model = self._teach_row(), self.state.robot
        if self.teach.read_check.isChecked() or row is None or model is None or not text.strip():
            self.teach.show_check([])
            return
        try:
            q_file = typed_joints(text, model)
        except RoboCalError as exc:
            self.teach.show_check([("bad", f"{exc.problem}. {exc.hint or ''}".strip())])
            return
        far = off_plan(model, q_file, self.poses.q_file[row.index])
        self.teach.show_check([("ok", "Inside the joint limits.")] +
                              [("warn", f"{w}: check the pendant.") for w in far])

    def _use_plan(self) -> None:
        row = self._teach_row()
        if row is not None:
            self.teach.joints_edit.setText(" ".join(f"{v:g}" for v in self.poses.q_file[row.index]))

    # -- recording -------------------------------------------------------------------------
    def record_pose(self) -> bool:
        """Record the pose shown where the robot is now (a worker task); False when refused."""
        if self.task.busy:
            return False
        try:
            trained, src = self._inputs()
        except RoboCalError as exc:
            self._set_status(f"Cannot record: {exc.message}. {exc.hint or ''}".strip(), False)
            return False
        row, model = self._teach_row(), self.state.robot
        if row is None:
            self._set_status("Every pose is measured.", None)
            return False
        driver = self._readable() if self.teach.read_check.isChecked() else None
        typed = None
        if driver is None:
            try:
                typed = typed_joints(self.teach.joints_edit.text(), model)
            except RoboCalError as exc:
                self._set_status(f"✗ Pose {row.pose} not recorded: {exc.problem}. {exc.hint or ''}".strip(), False)
                return False
            if self.state.hardware.cameras is None and self.state.virtual:
                self._set_status("The virtual lab's cameras see the simulated robot: read its joints from the "
                                 "controller (jog it on the Setup page), or open cameras.", False)
                return False
        planned, path = self.poses.q_file[row.index], self.measurements_path()

        def go(lab):
            try:
                source = capture_source(self.state.hardware.cameras, lab=lab, driver=driver, seed=int(self.state.seed))
            except RoboCalError as exc:
                self._set_status(f"Cannot record: {exc.message}", False)
                return False
            return self.task.start(record_taught_pose, row.pose, planned, path, trained, src.rect, source, model,
                              driver=driver, q_typed_file=typed, on_done=self._taught, on_failed=self._teach_failed,
                              label="Recording", status=f"Recording pose {row.pose}…")

        return self.task.with_lab(go) if self.state.hardware.cameras is None and self.state.virtual else go(None)

    def _taught(self, taught) -> None:
        outcome = taught.outcome
        self._pose_done(self._run_id, outcome, taught.thumbnail)
        if self.is_complete():
            self.state.set_measurements(self.measurements_path())
        self.teach.joints_edit.clear()
        nxt = self._teach_row()
        then = f" Next: pose {nxt.pose}." if nxt is not None else " Every pose is done."
        off = f" ({'; '.join(taught.warnings)})" if taught.warnings else ""
        if outcome.status == MEASURED:
            self._set_status(f"✓ Pose {outcome.pose} recorded{off}.{then}", None if nxt is not None else True)
        else:
            self._set_status(f"✗ Pose {outcome.pose} rejected: {outcome.reason}. Bring the robot there again and "
                             f"record it, or select another pose.", False)
        self._show_teach()
        self.teach.show_check([("warn", w) for w in taught.warnings])

    def _teach_failed(self, message: str) -> None:
        self._set_status(f"✗ Not recorded: {message}", False)
        self._show_teach()
