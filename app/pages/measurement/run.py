"""The measurement run of the Measurement page: start or resume, pause and continue, cancel,
the poses as they come in, the outcome, start over.

In the virtual lab the simulated robot moves and the lab renders each pair
(app.jobs.measurement.measure_virtual). With a serial robot or chosen cameras the run goes
over them (app.jobs.measurement_hardware.measure_hardware): app.safety checks every target and
asks before the first motion; a fault stops the run, keeps what was measured, and Measure the rest
continues with the first pose not measured once the robot is connected again.

A mixin of MeasurementPage (before WizardPage): it uses the page's `rows`,
`poses`, `controls`, `table`, `pair`, `poseDone` signal and drawing methods.
"""
from __future__ import annotations

from PySide6.QtWidgets import QMessageBox

from app import messages
from app.jobs.measurement import MEASURED, PENDING, REJECTED, RUNNING, measure_virtual, move_aside
from app.jobs.measurement_hardware import capture_source, measure_hardware
from app.pages.measurement_inputs import measurement_inputs, project_marker, stereo_source
from app.safety import motion_refused
from core.errors import RoboCalError
from core.measurement.run import PoseOutcome, rejects_path_for
from core.provenance import fingerprint, record_inputs, recorded_inputs


class RunMixin:
    """Start / Measure the rest through the page's task once the lab exists; the pause event and the run
    id (the poses an older run reports are dropped) are the run's own."""

    def _inputs(self):
        """(trained marker, stereo source) or a RoboCalError saying what is missing."""
        state = self.state
        if state.project is None or state.robot is None:
            raise RoboCalError("no project or robot yet", hint="Create a project and choose a robot (Setup step).")
        if self.poses is None:
            raise RoboCalError("no pose list", hint="Select poses in step 4, or load a poses CSV.")
        trained = project_marker(state)
        if trained is None:
            raise RoboCalError("no trained marker", hint="Train the marker in step 3 (Marker).")
        src = stereo_source(state)
        if src.rect is None:
            raise RoboCalError(src.problem or "no stereo calibration",
                               hint="Calibrate the cameras in step 2 and save stereo.yaml.")
        return trained, src

    def _robot_ready(self) -> bool:
        """The robot connection can move (else the reason in the status line)."""
        driver = self.state.hardware.robot_connection
        if driver is None:
            self._set_status("No robot connection (Setup step).", False)
            return False
        if driver.stopped:
            self._set_status("The robot is stopped. When the way is clear: Robot ▸ Resume after stop, then Measure "
                             "the rest.", False)
            return False
        return True

    def start_run(self) -> bool:
        """Start the run, or resume it after the last measured or rejected pose."""
        if self.task.busy:
            return False
        try:
            self._inputs()
        except RoboCalError as exc:
            self._set_status(f"Cannot measure: {exc.message}. {exc.hint or ''}".strip(), False)
            return False
        if self.teach_mode:
            self._set_status("Teach mode: bring the robot to the pose shown below, then Record pose.", None)
            return False
        if self.on_hardware:
            refused = self._hardware_refused()
            if refused:
                self._set_status(refused, False)
                return False
            if self.state.hardware.cameras is not None:
                return self._measure(None)
        elif not self._robot_ready():
            return False
        # the lab first (it replaces the simulated robot connection, renders the pairs), then the run
        return self.task.with_lab(self._measure)

    @property
    def on_hardware(self) -> bool:
        """The run goes over a serial robot or the chosen cameras, not the virtual lab alone."""
        state = self.state
        return state.hardware.real_robot or state.hardware.cameras is not None or not state.virtual

    def _hardware_refused(self) -> str | None:
        """Why the robot may not go through the poses still to measure (None: it may; the first
        motion of a real robot is confirmed here)."""
        state = self.state
        if state.hardware.cameras is None and not state.virtual:
            return "No cameras: open the two cameras on the Setup page."
        driver = state.hardware.robot_connection
        lost = getattr(driver, "lost", None)
        if lost:
            return (f"The connection to the robot is lost ({lost}). Connect the robot again on the Setup page, "
                    "then Measure the rest.")
        Q = self.poses.Q[[r.index for r in self._pending()]]
        return motion_refused(self, state, Q)

    def _measure(self, lab) -> bool:
        try:
            trained, src = self._inputs()
        except RoboCalError as exc:
            self._set_status(f"Cannot measure: {exc.message}. {exc.hint or ''}".strip(), False)
            self._finish_autopilot(False, exc.message)
            return False
        if not self._robot_ready():
            self._finish_autopilot(False, self.status.text())
            return False
        self._run_id += 1
        run_id = self._run_id
        self.controls.pause_button.setChecked(False)
        self._pause.clear()
        self.result = None
        pending = len(self._pending())
        done = len(self.rows) - pending
        self._made_from = (fingerprint(measurement_inputs(self.state.project)), done == 0)
        status = (f"Measuring {pending} pose{'s' if pending != 1 else ''}"
                  + (f" (continuing after the {done} done earlier)" if done else "") + "… Esc stops the robot.")
        driver, path = self.state.hardware.robot_connection, self.measurements_path()
        if self.on_hardware:
            try:
                source = capture_source(self.state.hardware.cameras, lab=lab, driver=driver, seed=int(self.state.seed))
            except RoboCalError as exc:
                self._set_status(f"Cannot measure: {exc.message}", False)
                self._finish_autopilot(False, exc.message)
                return False
            job, args = measure_hardware, (self.poses, path, trained, src.rect, driver, source)
        else:
            job, args = measure_virtual, (self.poses, path, trained, src.rect, driver, lab, int(self.state.seed))
        return self.task.start(job, *args, paused=self._pause.is_set,
                          report=lambda outcome, thumb: self.poseDone.emit(run_id, outcome, thumb),
                          on_done=self._finished, on_failed=self._run_failed, on_cancelled=self._run_cancelled,
                          label="Measuring", status=status)

    def pause(self, on: bool = True) -> None:
        self.controls.pause_button.setChecked(bool(on))

    def _pause_toggled(self, on: bool) -> None:
        if on:
            self._pause.set()
        else:
            self._pause.clear()
        if self.task.busy:
            self._set_status("Paused after the current pose: Continue when ready." if on else "Measuring…", None)

    def on_cancel_requested(self) -> None:
        if not self.task.waiting_for_lab and self.task.busy:
            self._set_status("Cancelling after the current pose…", None)

    def on_progress(self, fraction: float, message: str) -> None:
        if message.startswith("pose "):            # "pose <id> (k/n)": that pose is being measured
            try:
                pid = int(message.split()[1])
            except (IndexError, ValueError):
                return
            i = self._row_of.get(pid)
            if i is not None and self.rows[i].status == PENDING:
                self.rows[i].status = RUNNING
                self.table.set_row(i, self.rows[i])

    def _pose_done(self, run_id: int, outcome: PoseOutcome, thumb) -> None:
        i = self._row_of.get(int(outcome.pose))
        if run_id != self._run_id or i is None:
            return
        r = self.rows[i]
        r.status = MEASURED if outcome.status == MEASURED else REJECTED
        r.reason, r.point, r.sigma = outcome.reason, outcome.point, outcome.sigma
        self.table.set_row(i, r)
        if thumb is not None:
            self.pair.show_pair(outcome.pose, thumb, r.status == MEASURED, r.reason)
        self._show_summary()
        self._show_views(highlight=i)
        self.table.selectRow(i)            # scrolls to it and draws its arm
        self.notify_complete()

    def _end(self) -> None:
        """A run ended: the files are the truth."""
        self.controls.pause_button.setChecked(False)
        self._pause.clear()
        self._record_inputs()
        self._read_existing()
        done = sum(1 for r in self.rows if r.status in (MEASURED, REJECTED))
        self.controls.show_done(done, len(self.rows))
        self._redraw()

    def _record_inputs(self) -> None:
        """Record beside measurements.csv the stereo.yaml and marker.npz the run measured with: a
        run from the first pose records them; a continued run keeps the record (a record of other
        inputs stays, so that the mixed file is out of date; a file without one stays unknown)."""
        made_from, fresh = self._made_from
        self._made_from = (None, False)
        path = self.measurements_path()
        if made_from is None or path is None or not path.is_file():
            return
        if fresh or recorded_inputs(path) == made_from:
            try:
                record_inputs(path, made_from, hashed=True)
            except RoboCalError as exc:
                self._set_status(f"The record of the run's inputs was not written: {exc.message}", False)

    def _robot_stopped(self) -> bool:
        driver = self.state.hardware.robot_connection
        return driver is not None and driver.stopped

    def _stopped_text(self, kept: str) -> str:
        return (f"Robot stopped: the run stopped before pose {self._next_pose_text()}. {kept}. "
                "When the way is clear: Robot ▸ Resume after stop, then Measure the rest.")

    def _finished(self, result) -> None:
        self.result = result
        self._end()
        c = self.counts()
        kept = f"{c[MEASURED]} measured and {c[REJECTED]} rejected poses are in {result.measurements_path.name}"
        if result.fault:
            if self._robot_stopped():                 # the run stopped the robot: the window offers Resume
                self.state.hardware.stoppedChanged.emit(True)
            nxt = self._next_pose_text()
            self._set_status(f"✗ Stopped before pose {nxt}: {result.fault.rstrip('.')}. {kept}; Measure the rest starts "
                             f"at pose {nxt} (connect the robot again on the Setup page first).", False)
            self._finish_autopilot(False, result.fault)
            return
        if result.cancelled:
            if self._robot_stopped():
                self._set_status(self._stopped_text(kept), False)
                self._finish_autopilot(False, "the robot was stopped")
            else:
                self._set_status(f"Cancelled. {kept}. Measure the rest starts at pose {self._next_pose_text()}.", False)
                self._finish_autopilot(False, "cancelled")
            return
        if self.state.project is not None and self.measurements_path().is_file():
            self.state.set_measurements(self.measurements_path())
        if self.is_complete():
            self._set_status(f"✓ Done: {c[MEASURED]} of {len(self.rows)} poses measured"
                             + (f", {c[REJECTED]} rejected (see the reasons)" if c[REJECTED] else "")
                             + f". Identification needs at least {self.n_min}: enough.", True)
            self._finish_autopilot(True, self._done_message())
        else:
            self._set_status(f"Only {c[MEASURED]} poses measured; identification needs at least {self.n_min}. "
                             "Check the rejection reasons, add poses (step 4) and measure again.", False)
            self._finish_autopilot(False, f"only {c[MEASURED]} poses measured (at least {self.n_min} needed)")

    def _run_failed(self, message: str) -> None:
        self._end()
        if self._robot_stopped():
            self._set_status(self._stopped_text(f"{self.counts()[MEASURED]} measured poses are in measurements.csv"),
                             False)
            self._finish_autopilot(False, "the robot was stopped")
            return
        if "another pose list" in message and self._autopilot_done is not None and not self._autopilot_retried:
            # the autopilot cannot ask: the old file is moved aside (kept), and the run starts again
            self._autopilot_retried = True
            if self.start_over(confirm=False) and self.start_run():
                return
        hint = " Use Start over to move the old file aside." if "another pose list" in message else ""
        self._set_status(f"✗ {message}{hint}", False)
        self._finish_autopilot(False, message)

    def _run_cancelled(self) -> None:
        self._end()
        self._set_status("Cancelled before the first pose.", False)
        self._finish_autopilot(False, "cancelled")

    def _next_pose_text(self) -> str:
        pending = self._pending()
        return str(pending[0].pose) if pending else "–"

    def start_over(self, confirm: bool = True) -> bool:
        """Move measurements.csv and its rejects file aside (renamed with the time), so that
        every pose is measured again. Nothing is deleted."""
        if self.task.busy or self.state.project is None:
            return False
        path = self.measurements_path()
        files = [p for p in (path, rejects_path_for(path)) if p.exists()]
        if not files:
            self._set_status("Nothing to move aside: no measurements yet.", None)
            return True
        if confirm and not messages.NON_INTERACTIVE:
            answer = QMessageBox.question(
                self, "RoboCal: start over",
                f"Move {', '.join(p.name for p in files)} aside (renamed, kept in the project folder) and measure "
                "every pose again?")
            if answer != QMessageBox.StandardButton.Yes:
                return False
        try:
            moved = move_aside(files)
        except RoboCalError as exc:
            self._set_status(f"✗ {exc.problem}", False)
            return False
        self.result = None
        self._read_existing()
        self._redraw()
        self._set_status(f"Moved aside: {', '.join(p.name for p in moved)}. Start measures every pose again.", None)
        return True
