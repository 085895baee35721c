"""The measurement run of the Measurement page: start or resume, pause and continue, cancel,
the poses as they come in, the outcome, start over.

In the virtual lab the simulated robot moves and the lab renders each pair
(app.jobs.measurement.measure_virtual). With a serial robot or chosen cameras the run goes
over them (app.jobs.measurement_hardware.measure_hardware): app.safety checks every target and
asks before the first motion; a fault stops the run, keeps what was measured, and Measure the rest
continues with the first pose not measured once the robot is connected again.

`MeasurementRun` is held by the page (composed, not a base class): it keeps the pause event, the
run id (the poses an older run reports are dropped) and the inputs the run measured with, and
writes what it learns into the page's MeasurementModel.
"""
from __future__ import annotations

import threading
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

from PySide6.QtWidgets import QMessageBox, QWidget

from app import messages
from app.jobs.measurement import MEASURED, REJECTED, measure_virtual, move_aside
from app.jobs.measurement_hardware import capture_source, measure_hardware
from app.pages.measurement.controls import RunControls
from app.pages.measurement.model import MeasurementModel
from app.pages.measurement_inputs import measurement_inputs, run_inputs
from app.pages.page_task import PageTask
from app.safety import motion_refused
from core.errors import RoboCalError
from core.measurement.run import PoseOutcome, rejects_path_for
from core.provenance import fingerprint, record_inputs, recorded_inputs


@dataclass
class RunHooks:
    """What the run needs of its page, as plain callables on the GUI thread."""

    say: Callable[[str, bool | None], None]                 # the page's status line (ok: green, False: amber)
    finish_autopilot: Callable[[bool, str], None]           # tell the autopilot once (nothing when none runs)
    autopilot_running: Callable[[], bool]
    post: Callable[[int, PoseOutcome, object], None]        # (run id, outcome, thumbnail) to the GUI thread
    measurements_path: Callable[[], Path | None]
    teach_mode: Callable[[], bool]
    is_complete: Callable[[], bool]


class MeasurementRun:
    """Start / Measure the rest through the page's task once the lab exists; Pause, Cancel after
    the current pose, Start over."""

    def __init__(self, model: MeasurementModel, task: PageTask, state, controls: RunControls, hooks: RunHooks,
                 parent: QWidget):
        self.model, self.task, self.state, self.controls, self.hooks = model, task, state, controls, hooks
        self._parent = parent                        # the questions' window
        self._pause = threading.Event()
        self._run_id = 0                             # the poses reported by an older run are dropped
        self._made_from = (None, False)              # (inputs' digests, from the first pose) of the run
        self.autopilot_retried = False               # the autopilot moved a file of another pose list aside once

    @property
    def paused(self) -> bool:
        return self._pause.is_set()

    @property
    def on_hardware(self) -> bool:
        """The run goes over a serial robot or the chosen cameras, not the virtual lab alone."""
        state = self.state
        return state.hardware.real_robot or state.hardware.cameras is not None or not state.virtual

    def forget(self) -> None:
        """Another project or robot: nothing of an older run counts, no pause."""
        self._run_id += 1
        self._pause.clear()

    def _robot_refusal(self) -> str | None:
        """Why the robot connection cannot move (None: it can)."""
        driver = self.state.hardware.robot_connection
        if driver is None:
            return "No robot connection (Setup step)."
        if driver.stopped:
            return "The robot is stopped. When the way is clear: Robot ▸ Resume after stop, then Measure the rest."
        return None

    def start(self) -> bool:
        """Start the run, or resume it after the last measured or rejected pose."""
        if self.task.busy:
            return False
        try:
            run_inputs(self.state, self.model.poses)
        except RoboCalError as exc:
            self.hooks.say(f"Cannot measure: {exc.message}. {exc.hint or ''}".strip(), False)
            return False
        if self.hooks.teach_mode():
            self.hooks.say("Teach mode: bring the robot to the pose shown below, then Record pose.", None)
            return False
        refused = self._hardware_refused() if self.on_hardware else self._robot_refusal()
        if refused:
            self.hooks.say(refused, False)
            return False
        if self.on_hardware and self.state.hardware.cameras is not None:
            return self._measure(None)
        # the lab first (it replaces the simulated robot connection, renders the pairs), then the run
        return self.task.with_lab(self._measure)

    def _hardware_refused(self) -> str | None:
        """Why the robot may not go through the poses still to measure (None: it may; the first
        motion of a real robot is confirmed here)."""
        state = self.state
        if state.hardware.cameras is None and not state.virtual:
            return "No cameras: open the two cameras on the Setup page."
        lost = getattr(state.hardware.robot_connection, "lost", None)
        if lost:
            return (f"The connection to the robot is lost ({lost}). Connect the robot again on the Setup page, "
                    "then Measure the rest.")
        Q = self.model.poses.Q[[r.index for r in self.model.pending()]]
        return motion_refused(self._parent, state, Q)

    def _cannot(self, message: str, why: str) -> bool:
        self.hooks.say(message, False)
        self.hooks.finish_autopilot(False, why)
        return False

    def _measure(self, lab) -> bool:
        try:
            trained, src = run_inputs(self.state, self.model.poses)
        except RoboCalError as exc:
            return self._cannot(f"Cannot measure: {exc.message}. {exc.hint or ''}".strip(), exc.message)
        refused = self._robot_refusal()
        if refused:
            return self._cannot(refused, refused)
        self._run_id += 1
        run_id = self._run_id
        self.controls.pause_button.setChecked(False)
        self._pause.clear()
        self.model.set_result(None)
        pending = len(self.model.pending())
        done = len(self.model.rows) - pending
        self._made_from = (fingerprint(measurement_inputs(self.state.project)), done == 0)
        status = (f"Measuring {pending} pose{'s' if pending != 1 else ''}"
                  + (f" (continuing after the {done} done earlier)" if done else "") + "… Esc stops the robot.")
        driver, path, poses = self.state.hardware.robot_connection, self.hooks.measurements_path(), self.model.poses
        if self.on_hardware:
            try:
                source = capture_source(self.state.hardware.cameras, lab=lab, driver=driver, seed=int(self.state.seed))
            except RoboCalError as exc:
                return self._cannot(f"Cannot measure: {exc.message}", exc.message)
            job, args = measure_hardware, (poses, path, trained, src.rect, driver, source)
        else:
            job, args = measure_virtual, (poses, path, trained, src.rect, driver, lab, int(self.state.seed))
        return self.task.start(job, *args, paused=self._pause.is_set,
                               report=lambda outcome, thumb: self.hooks.post(run_id, outcome, thumb),
                               on_done=self._finished, on_failed=self._failed, on_cancelled=self._cancelled,
                               label="Measuring", status=status)

    def set_paused(self, on: bool) -> None:
        """Pause pressed (wait after the current pose) or released."""
        if on:
            self._pause.set()
        else:
            self._pause.clear()
        if self.task.busy:
            self.hooks.say("Paused after the current pose: Continue when ready." if on else "Measuring…", None)

    def cancel_requested(self) -> None:
        if not self.task.waiting_for_lab and self.task.busy:
            self.hooks.say("Cancelling after the current pose…", None)

    def progress(self, message: str) -> None:
        """A progress step: "pose <id> (k/n)" says that pose is being measured."""
        if message.startswith("pose "):
            try:
                pid = int(message.split()[1])
            except (IndexError, ValueError):
                return
            self.model.mark_running(pid)

    def pose_reported(self, run_id: int, outcome: PoseOutcome, thumb) -> None:
        """A pose of run `run_id` measured or rejected (on the GUI thread)."""
        if run_id == self._run_id:
            self.model.record(outcome, thumb)

    def _end(self) -> None:
        """A run ended: the files are the truth."""
        self.controls.pause_button.setChecked(False)
        self._pause.clear()
        self._record_inputs()
        self.model.read_rows(self.hooks.measurements_path())
        rows = self.model.rows
        self.controls.show_done(sum(1 for r in rows if r.status in (MEASURED, REJECTED)), len(rows))

    def _record_inputs(self) -> None:
        """Record beside measurements.csv the stereo.yaml and marker.npz the run measured with: a
        run from the first pose records them; a continued run keeps the record (a record of other
        inputs stays, so that the mixed file is out of date; a file without one stays unknown)."""
        made_from, fresh = self._made_from
        self._made_from = (None, False)
        path = self.hooks.measurements_path()
        if made_from is None or path is None or not path.is_file():
            return
        if fresh or recorded_inputs(path) == made_from:
            try:
                record_inputs(path, made_from, hashed=True)
            except RoboCalError as exc:
                self.hooks.say(f"The record of the run's inputs was not written: {exc.message}", False)

    def _robot_stopped(self) -> bool:
        driver = self.state.hardware.robot_connection
        return driver is not None and driver.stopped

    def _stopped_text(self, kept: str) -> str:
        return (f"Robot stopped: the run stopped before pose {self.model.next_pose_text()}. {kept}. "
                "When the way is clear: Robot ▸ Resume after stop, then Measure the rest.")

    def _finished(self, result) -> None:
        self.model.set_result(result)
        self._end()
        say, finish, c, n_min = self.hooks.say, self.hooks.finish_autopilot, self.model.counts(), self.model.n_min
        kept = f"{c[MEASURED]} measured and {c[REJECTED]} rejected poses are in {result.measurements_path.name}"
        if result.fault:
            if self._robot_stopped():                 # the run stopped the robot: the window offers Resume
                self.state.hardware.stoppedChanged.emit(True)
            nxt = self.model.next_pose_text()
            say(f"✗ Stopped before pose {nxt}: {result.fault.rstrip('.')}. {kept}; Measure the rest starts "
                f"at pose {nxt} (connect the robot again on the Setup page first).", False)
            finish(False, result.fault)
            return
        if result.cancelled:
            if self._robot_stopped():
                say(self._stopped_text(kept), False)
                finish(False, "the robot was stopped")
            else:
                say(f"Cancelled. {kept}. Measure the rest starts at pose {self.model.next_pose_text()}.", False)
                finish(False, "cancelled")
            return
        path = self.hooks.measurements_path()
        if self.state.project is not None and path.is_file():
            self.state.set_measurements(path)
        if self.hooks.is_complete():
            say(f"✓ Done: {c[MEASURED]} of {len(self.model.rows)} poses measured"
                + (f", {c[REJECTED]} rejected (see the reasons)" if c[REJECTED] else "")
                + f". Identification needs at least {n_min}: enough.", True)
            finish(True, self.model.done_message(path))
        else:
            say(f"Only {c[MEASURED]} poses measured; identification needs at least {n_min}. "
                "Check the rejection reasons, add poses (step 4) and measure again.", False)
            finish(False, f"only {c[MEASURED]} poses measured (at least {n_min} needed)")

    def _failed(self, message: str) -> None:
        self._end()
        if self._robot_stopped():
            kept = f"{self.model.counts()[MEASURED]} measured poses are in measurements.csv"
            self._cannot(self._stopped_text(kept), "the robot was stopped")
            return
        other_list = "another pose list" in message
        if other_list and self.hooks.autopilot_running() and not self.autopilot_retried:
            # the autopilot cannot ask: the old file is moved aside (kept), and the run starts again
            self.autopilot_retried = True
            if self.start_over(confirm=False) and self.start():
                return
        hint = " Use Start over to move the old file aside." if other_list else ""
        self._cannot(f"✗ {message}{hint}", message)

    def _cancelled(self) -> None:
        self._end()
        self._cannot("Cancelled before the first pose.", "cancelled")

    def start_over(self, confirm: bool = True) -> bool:
        """Move measurements.csv and its rejects file aside (renamed with the time), so that
        every pose is measured again. Nothing is deleted."""
        if self.task.busy or self.state.project is None:
            return False
        path = self.hooks.measurements_path()
        files = [p for p in (path, rejects_path_for(path)) if p.exists()]
        if not files:
            self.hooks.say("Nothing to move aside: no measurements yet.", None)
            return True
        if confirm and not messages.NON_INTERACTIVE:
            answer = QMessageBox.question(
                self._parent, "RoboCal: start over",
                f"Move {', '.join(p.name for p in files)} aside (renamed, kept in the project folder) and measure "
                "every pose again?")
            if answer != QMessageBox.StandardButton.Yes:
                return False
        try:
            moved = move_aside(files)
        except RoboCalError as exc:
            self.hooks.say(f"✗ {exc.problem}", False)
            return False
        self.model.set_result(None)
        self.model.read_rows(path)
        self.hooks.say(f"Moved aside: {', '.join(p.name for p in moved)}. Start measures every pose again.", None)
        return True
