"""Step 5, Measurement: drive the robot through the pose list, capture, locate, write as it goes.

The page runs app.jobs.measurement.measure_virtual (core.measurement.run.run_measurements) on a
worker thread: for each pose the robot (``state.hardware.robot_connection``; in the virtual lab a
SimulatedRobot, which refuses joint values outside the limits) moves, both cameras capture
(virtual lab: the pair rendered with a per-pose seeded generator), the marker is located
(core.marker.location.MarkerLocator with the trained marker and the project's stereo.yaml) and
the point is appended to the project's measurements.csv at once (flushed and fsynced per pose);
a pose that gives no point goes to measurements.rejects.csv with its reason.

Pause waits between poses; Cancel stops after the current pose; Start again resumes where
the run stopped (the poses already measured or rejected are skipped, nothing is measured
twice). Start over moves the old files aside (never deletes them). Stop (Esc, the main
window) stops the robot and cancels the run: the driver refuses every motion until the user
resumes it, and the run ends before the next pose. With a serial robot or chosen cameras the
run goes over them (run.py); teach mode records poses the technician brings the robot to
(teach.py).

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
from PySide6.QtWidgets import QFileDialog, QLabel, QSplitter, QVBoxLayout

from app.jobs.measurement import (MEASURED, PENDING, REJECTED, RUNNING, PoseRow, choose_pose_list, pose_rows,
                                  poses_needed)
from app.pages.base import WizardPage, out_of_date
from app.pages.measurement.controls import RunControls
from app.pages.measurement.pair_view import PairView
from app.pages.measurement.pose_table import PoseTable
from app.pages.measurement.run import RunMixin
from app.pages.measurement.teach import TeachMixin
from app.pages.measurement.teach_panel import TeachPanel
from app.pages.measurement.texts import counts, ready_text, sources_html, summary_html
from app.pages.measurement.views import MeasurementViews
from app.pages.measurement_inputs import measurement_inputs, project_marker, stereo_source
from app.pages.steps import Step
from core.errors import RoboCalError
from core.measurement.run import rejects_path_for
from core.poses.file import PoseList, read_pose_list
from core.project import Output
from core.provenance import changed_inputs
from widgets.workspace_views import camera_wedges


class MeasurementPage(RunMixin, TeachMixin, WizardPage):
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
        self._made_from = (None, False)             # (inputs' digests, from the first pose) of the run
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
        state.hardware.connectionChanged.connect(self._connection_changed)
        state.hardware.camerasChanged.connect(lambda *_: self._update_mode())
        self._context_changed()

    def _build(self) -> None:
        self.controls = RunControls(self.task.progress_row(), on_load=self.load_dialog, on_start=self.start_run,
                                    on_pause=self._pause_toggled, on_start_over=self.start_over,
                                    on_teach=self._teach_toggled)
        self.table = PoseTable()
        self.table.itemSelectionChanged.connect(self._selection_changed)
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
        self.teach = TeachPanel(on_record=self.record_pose, on_typed=self._typed_changed, on_use_plan=self._use_plan)
        self.teach.setVisible(False)
        self.splitter.addWidget(self.teach)
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
        return self.state.project.path(Output.MEASUREMENTS) if self.state.project is not None else None

    def counts(self):
        return counts(self.rows)

    @property
    def n_measured(self) -> int:
        return sum(1 for r in self.rows if r.status == MEASURED)

    def _lab(self):
        """The state's virtual lab when it exists (the views draw the nominal model with it)."""
        return self.state.labs.current

    def _lab_changed(self, lab) -> None:
        if lab is not None:
            self.views.forget_predictions()
            self._show_views()

    def _poses_changed(self) -> None:
        if not self.task.busy and self.loaded_csv is None:
            self._load_poses()

    def _sources_changed(self) -> None:
        if not self.task.busy:
            self._show_sources()
            self._show_views()

    def _context_changed(self, *_) -> None:
        self.task.forget()
        self._run_id += 1
        self._pause.clear()
        self.loaded_csv = None
        self.result = None
        self._load_poses()
        self._connection_changed()
        self.notify_complete()

    # -- poses and files ------------------------------------------------------------------------
    def _pose_list(self) -> str:
        """Read the pose list into `poses` and the minimum for identification into `n_min`;
        the problem or ""."""
        state, robot = self.state, self.state.robot
        self.poses, self.poses_label = None, ""
        if state.project is None or robot is None:
            return "No project or robot yet (Setup step)."
        project_poses = state.project.path(Output.POSES) if state.project.has(Output.POSES) else None
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
        elif not self.task.busy:
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
        if self.task.busy:
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
        if not self.task.busy:
            self._load_poses()
        self.notify_complete()

    def is_complete(self) -> bool:
        return self.n_min > 0 and self.n_measured >= self.n_min and not self.changed_inputs()

    def changed_inputs(self) -> list[str]:
        """stereo.yaml or marker.npz changed since measurements.csv was measured with them."""
        if self.state.project is None:
            return []
        return changed_inputs(self.measurements_path(), measurement_inputs(self.state.project))

    def on_busy_changed(self) -> None:
        self._update_buttons()

    def autopilot(self, done) -> None:
        if self.state.project is None or self.state.robot is None:
            done(False, "no project or robot model (Setup step)")
            return
        if self.task.busy:
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
        self.controls.set_buttons(busy=self.task.busy, can_start=self.poses is not None and pending,
                                  resume=done_before and pending, can_start_over=done_before or on_disk,
                                  teach=self.teach_mode)
        self.controls.teach_check.setEnabled(not self.task.busy and (self.state.virtual or self._drivable()))
        self._show_teach()

    def _ready_status(self) -> None:
        changed = self.changed_inputs()
        if changed and not self._pending():
            self._set_status(out_of_date("measurements.csv", changed,
                                         "Start over… to measure every pose with them."), False)
            return
        c = self.counts()
        complete = self.is_complete()
        ok = False if self._file_problem else (complete if not self._pending() and c[MEASURED] else None)
        self._set_status(ready_text(self.rows, self.n_min, self._file_problem, complete, self.teach_mode), ok)

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

    def _selection_changed(self) -> None:
        self.views.highlight_row(self.rows, self._joints(), self._lab(), self.table.selected())
        self._show_teach()

    def _show_views(self, highlight: int | None = None) -> None:
        self.views.show_rows(self.rows, self._joints(), self._lab(), self._wedges,
                             self.table.selected() if highlight is None else highlight)
