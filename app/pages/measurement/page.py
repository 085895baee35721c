"""Step 5, Measurement: drive the robot through the pose list, capture, locate, write as it goes.

The page runs app.jobs.measurement.measure_virtual (core.measurement.run.run_measurements) on a
worker thread: for each pose the robot (``state.robot_connection``; in the virtual lab a
SimulatedRobot, which refuses joint values outside the limits) moves, both cameras capture
(virtual lab: the pair rendered with a per-pose seeded generator), the marker is located
(core.marker.location.MarkerLocator with the trained marker and the project's stereo.yaml) and
the point is appended to the project's measurements.csv at once (flushed and fsynced per pose);
a pose that gives no point goes to measurements.rejects.csv with its reason.

Pause waits between poses; Cancel stops after the current pose; Start again resumes where
the run stopped (the poses already measured or rejected are skipped, nothing is measured
twice). Start over moves the old files aside (never deletes them). Stop (Esc, the main
window) stops the robot and cancels the run: the driver refuses every motion until the user
resumes it, and the run ends before the next pose.

The page shows the poses with their status (measured / rejected with the reason / pending),
the current pair as a thumbnail, the measured points in two orthographic views (with the
nominal model's predictions in the virtual lab), and a summary. The step is complete when
measurements.csv holds at least as many poses as identification needs; the path goes to
``state.measurements``.
"""
from __future__ import annotations

import threading
from pathlib import Path

from PySide6.QtCore import Qt, Signal
from PySide6.QtWidgets import QFileDialog, QLabel, QMessageBox, QSplitter, QVBoxLayout

from app import messages
from app.jobs.measurement import (MEASURED, PENDING, REJECTED, RUNNING, PoseRow, choose_pose_list, measure_virtual,
                                  move_aside, pose_rows, poses_needed)
from app.pages.base import WizardPage
from app.pages.lab_wait import LabWaitMixin
from app.pages.measurement.controls import RunControls
from app.pages.measurement.pair_view import PairView
from app.pages.measurement.pose_table import PoseTable
from app.pages.measurement.texts import counts, ready_text, sources_html, summary_html
from app.pages.measurement.views import MeasurementViews
from app.pages.measurement_inputs import project_marker, stereo_source
from app.pages.steps import Step
from core.errors import RoboCalError
from core.measurement.run import PoseOutcome, rejects_path_for
from core.poses.file import PoseList, read_pose_list
from widgets.workspace_views import camera_wedges


class MeasurementPage(LabWaitMixin, WizardPage):
    step = Step.MEASUREMENT

    #: (run id, PoseOutcome, thumbnail or None), emitted from the worker thread
    poseDone = Signal(int, object, object)

    def __init__(self, state, tasks, **kwargs):
        super().__init__(state, tasks, **kwargs)
        self.poses: PoseList | None = None
        self.poses_label = ""
        self.loaded_csv: Path | None = None        # a CSV the user loaded instead of the project's poses
        self.rows: list[PoseRow] = []
        self._row_of: dict[int, int] = {}
        self.n_min = 0
        self.result = None                          # the last MeasurementRunResult
        self._pause = threading.Event()
        self._run_id = 0                            # the poses reported by an older run are dropped
        self._autopilot_retried = False
        self._wedges = None
        self._file_problem = ""
        self._build()
        self.poseDone.connect(self._pose_done)
        state.projectChanged.connect(self._context_changed)
        state.robotChanged.connect(self._context_changed)
        state.labChanged.connect(self._lab_changed)
        state.posesChanged.connect(lambda *_: self._poses_changed())
        state.markerChanged.connect(lambda *_: self._sources_changed())
        state.stereoChanged.connect(lambda *_: self._sources_changed())
        state.connectionChanged.connect(lambda *_: self._update_buttons())
        self._context_changed()

    def _build(self) -> None:
        self.controls = RunControls(self.progress_row(), on_load=self.load_dialog, on_start=self.start_run,
                                    on_pause=self._pause_toggled, on_start_over=self.start_over)
        self.table = PoseTable()
        self.table.itemSelectionChanged.connect(lambda: self.views.highlight_row(
            self.rows, self._joints(), self._lab(), self.table.selected()))
        self.pair = PairView()
        upper = QSplitter(Qt.Orientation.Horizontal)
        upper.addWidget(self.table)
        upper.addWidget(self.pair)
        upper.setChildrenCollapsible(False)
        upper.setStretchFactor(0, 5)
        upper.setStretchFactor(1, 4)
        self.views = MeasurementViews()
        self.splitter = QSplitter(Qt.Orientation.Vertical)
        self.splitter.addWidget(upper)
        self.splitter.addWidget(self.views)
        self.splitter.setChildrenCollapsible(False)
        self.splitter.setStretchFactor(0, 5)
        self.splitter.setStretchFactor(1, 5)
        self.splitter.setSizes([260, 300])
        self.summary = QLabel()
        self.summary.setObjectName("summaryLabel")
        self.summary.setWordWrap(True)
        self.summary.setTextFormat(Qt.TextFormat.RichText)
        layout = QVBoxLayout(self)
        layout.setContentsMargins(0, 0, 0, 0)
        layout.setSpacing(6)
        layout.addWidget(self.controls)
        layout.addWidget(self.splitter, 1)
        layout.addWidget(self.summary)
        layout.addWidget(self.status)

    # -- state ------------------------------------------------------------------------------
    @property
    def paused(self) -> bool:
        return self._pause.is_set()

    def measurements_path(self) -> Path | None:
        return self.state.project.path("measurements") if self.state.project is not None else None

    def counts(self):
        return counts(self.rows)

    @property
    def n_measured(self) -> int:
        return sum(1 for r in self.rows if r.status == MEASURED)

    def _lab(self):
        """The state's virtual lab when it exists (the views draw the nominal model with it)."""
        return self.state.lab if self.state.has_lab else None

    def _lab_changed(self, lab) -> None:
        if lab is not None:
            self.views.forget_predictions()
            self._show_views()

    def _poses_changed(self) -> None:
        if not self.busy and self.loaded_csv is None:
            self._load_poses()

    def _sources_changed(self) -> None:
        if not self.busy:
            self._show_sources()
            self._show_views()

    def _context_changed(self, *_) -> None:
        self.forget_task()
        self._run_id += 1
        self._pause.clear()
        self.loaded_csv = None
        self.result = None
        self._load_poses()
        self.notify_complete()

    # -- poses and files ------------------------------------------------------------------------
    def _pose_list(self) -> str:
        """Read the pose list into `poses` and the minimum for identification into `n_min`;
        the problem or ""."""
        state, robot = self.state, self.state.robot
        self.poses, self.poses_label = None, ""
        if state.project is None or robot is None:
            return "No project or robot yet (Setup step)."
        project_poses = state.project.path("poses") if state.project.has("poses") else None
        self.poses, self.poses_label, problem = choose_pose_list(robot, loaded_csv=self.loaded_csv,
                                                                 project_poses=project_poses, selection=state.poses)
        self.n_min = poses_needed(robot, state.poses)
        return problem

    def _load_poses(self) -> None:
        """The pose list, the minimum for identification, and what is already on disk."""
        problem = self._pose_list()
        self.views.forget_predictions()
        self._read_existing()
        self._show_sources()
        self._redraw()
        if problem:
            self._set_status(problem, False)
        elif not self.busy:
            self._ready_status()
        if self.is_complete() and self.state.measurements is None:
            self.state.set_measurements(self.measurements_path())      # measured in an earlier session

    def _read_existing(self) -> None:
        """Statuses from measurements.csv and its rejects file (an earlier run of this list)."""
        self.rows, self._file_problem = pose_rows(self.poses, self.measurements_path())
        self._row_of = {r.pose: r.index for r in self.rows}

    def load_dialog(self) -> bool:
        start = str(self.state.project.folder) if self.state.project is not None else ""
        path, _ = QFileDialog.getOpenFileName(self, "Poses to measure", start, "Poses CSV (*.csv);;All files (*)")
        return self.load_csv(path) if path else False

    def load_csv(self, path: str | Path) -> bool:
        """Measure the poses of this CSV (they go to the project's measurements.csv)."""
        if self.busy:
            return False
        if self.state.robot is None:
            self._set_status("Choose a robot model in the Setup step first.", False)
            return False
        try:
            read_pose_list(path, self.state.robot)
        except RoboCalError as exc:
            self._set_status(f"✗ {exc.message}", False)
            return False
        self.loaded_csv = Path(path)
        self._load_poses()
        return True

    # -- WizardPage -------------------------------------------------------------------------
    def on_enter(self) -> None:
        if not self.busy:
            self._load_poses()
        self.notify_complete()

    def is_complete(self) -> bool:
        return self.n_min > 0 and self.n_measured >= self.n_min

    def on_busy_changed(self) -> None:
        self._update_buttons()

    def autopilot(self, done) -> None:
        if self.state.project is None or self.state.robot is None:
            done(False, "no project or robot model (Setup step)")
            return
        if self.busy:
            done(False, "the page is busy")
            return
        self._load_poses()
        self._autopilot_done = done
        self._autopilot_retried = False
        if self.poses is not None and not self._pending() and self.is_complete():
            self._finish_autopilot(True, self._done_message())
            return
        if not self.start_run():
            self._finish_autopilot(False, self.status.text() or "the measurement could not start")

    def _done_message(self) -> str:
        c = self.counts()
        return (f"{c[MEASURED]} poses measured, {c[REJECTED]} rejected (identification needs {self.n_min}) "
                f"→ {self.measurements_path().name}")

    def _pending(self) -> list[PoseRow]:
        return [r for r in self.rows if r.status in (PENDING, RUNNING)]

    # -- the run ----------------------------------------------------------------------------------
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
        driver = self.state.robot_connection
        if driver is None:
            self._set_status("No robot connection (Setup step).", False)
            return False
        if driver.stopped:
            self._set_status("The robot is stopped. When the way is clear: Robot ▸ Resume after stop, then Resume "
                             "the run.", False)
            return False
        return True

    def start_run(self) -> bool:
        """Start the run, or resume it after the last measured or rejected pose."""
        if self.busy:
            return False
        try:
            self._inputs()
        except RoboCalError as exc:
            self._set_status(f"Cannot measure: {exc.message}. {exc.hint or ''}".strip(), False)
            return False
        if not self.state.virtual:
            self._set_status("Capturing from real cameras arrives with the hardware issue. Meanwhile save the "
                             "pairs with your camera software and use `robocal measure`.", False)
            return False
        if not self._robot_ready():
            return False
        # the lab first (it replaces the robot connection), then the run
        return self.when_lab(self._measure)

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
        status = (f"Measuring {pending} pose{'s' if pending != 1 else ''}"
                  + (f" (continuing after the {done} done earlier)" if done else "") + "… Esc stops the robot.")
        return self.start(measure_virtual, self.poses, self.measurements_path(), trained, src.rect,
                          self.state.robot_connection, lab, int(self.state.seed), paused=self._pause.is_set,
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
        if self.busy:
            self._set_status("Paused after the current pose: Continue when ready." if on else "Measuring…", None)

    def cancel(self) -> None:
        waiting = bool(self._lab_wait)
        super().cancel()
        if not waiting and self.busy:
            self._set_status("Cancelling after the current pose…", None)

    def _task_progress(self, fraction: float, message: str) -> None:
        super()._task_progress(fraction, message)
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
        self._read_existing()
        done = sum(1 for r in self.rows if r.status in (MEASURED, REJECTED))
        self.controls.show_done(done, len(self.rows))
        self._redraw()

    def _robot_stopped(self) -> bool:
        driver = self.state.robot_connection
        return driver is not None and driver.stopped

    def _stopped_text(self, kept: str) -> str:
        return (f"Robot stopped: the run stopped before pose {self._next_pose_text()}. {kept}. "
                "When the way is clear: Robot ▸ Resume after stop, then Resume.")

    def _finished(self, result) -> None:
        self.result = result
        self._end()
        c = self.counts()
        kept = f"{c[MEASURED]} measured and {c[REJECTED]} rejected poses are in {result.measurements_path.name}"
        if result.cancelled:
            if self._robot_stopped():
                self._set_status(self._stopped_text(kept), False)
                self._finish_autopilot(False, "the robot was stopped")
            else:
                self._set_status(f"Cancelled. {kept}. Resume continues with pose {self._next_pose_text()}.", False)
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
        if self.busy or self.state.project is None:
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

    # -- drawing ----------------------------------------------------------------------------------
    def _redraw(self) -> None:
        """Table, summary, views and buttons from `rows`; tell the wizard whether the step is done."""
        self.table.set_rows(self.rows)
        self._show_summary()
        self._show_views()
        self._update_buttons()
        self.notify_complete()

    def _update_buttons(self) -> None:
        path = self.measurements_path()
        on_disk = path is not None and (path.exists() or rejects_path_for(path).exists())
        done_before = any(r.status != PENDING for r in self.rows)
        pending = bool(self._pending())
        self.controls.set_buttons(busy=self.busy, can_start=self.poses is not None and pending,
                                  resume=done_before and pending, can_start_over=done_before or on_disk)

    def _ready_status(self) -> None:
        c = self.counts()
        complete = self.is_complete()
        ok = False if self._file_problem else (complete if not self._pending() and c[MEASURED] else None)
        self._set_status(ready_text(self.rows, self.n_min, self._file_problem, complete), ok)

    def _show_sources(self) -> None:
        src = stereo_source(self.state) if self.state.project is not None else None
        self._wedges = camera_wedges(src.rect.rig, 1000.0) if src is not None and src.rect is not None else None
        try:
            trained = project_marker(self.state)
            marker = f"trained ({trained.n_image_features} features)" if trained else "not trained (step 3)"
            marker_ok = trained is not None
        except RoboCalError as exc:
            marker, marker_ok = exc.message, False
        stereo_ok = src is not None and src.rect is not None
        stereo = src.label if stereo_ok else (src.problem if src is not None else "no project")
        self.controls.source_label.setText(sources_html(self.poses_label, marker, marker_ok, stereo, stereo_ok))

    def _show_summary(self) -> None:
        self.summary.setText(summary_html(self.rows, self.n_min))

    def _joints(self):
        """Every pose's joint values (rad / mm), or None."""
        return self.poses.Q if self.poses is not None else None

    def _show_views(self, highlight: int | None = None) -> None:
        self.views.show_rows(self.rows, self._joints(), self._lab(), self._wedges,
                             self.table.selected() if highlight is None else highlight)
