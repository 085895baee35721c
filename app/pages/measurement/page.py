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
run goes over them (run.py's MeasurementRun); teach mode records poses the technician brings
the robot to (teach.py's Teaching).

The page shows the poses with their status (measured / rejected with the reason / pending),
the current pair as a thumbnail, the measured points in two orthographic views (with the
nominal model's predictions in the virtual lab), and a summary. The step is complete when
measurements.csv holds at least as many poses as identification needs; the path goes to
``state.measurements``.

The page is a small controller: the pose list, each pose's status and the last run's result are
in a Qt-free MeasurementModel (model.py) that the table, the pair, the views and the summary
follow; the run and teach mode are helpers the page holds.
"""
from __future__ import annotations

from dataclasses import replace
from pathlib import Path

from PySide6.QtCore import Qt, Signal
from PySide6.QtWidgets import QSplitter, QVBoxLayout

from app.jobs.measurement import PENDING, PoseRow
from app.pages.base import WizardPage
from app.pages.measurement.controls import RunControls
from app.pages.measurement.model import MeasurementModel
from app.pages.measurement.pair_view import PairView
from app.pages.measurement.pose_list import InputsHooks, PoseListInputs
from app.pages.measurement.pose_table import PoseTable
from app.pages.measurement.run import MeasurementRun, RunHooks
from app.pages.measurement.teach import TeachHooks, Teaching
from app.pages.measurement.teach_panel import TeachPanel
from app.pages.measurement.summary import SummaryLabel
from app.pages.measurement.views import MeasurementViews
from app.pages.measurement_inputs import measurement_inputs
from app.pages.steps import Step
from core.measurement.run import rejects_path_for
from core.poses.file import PoseList
from core.project import Output
from core.provenance import changed_inputs


class MeasurementPage(WizardPage):
    step = Step.MEASUREMENT

    #: (run id, PoseOutcome, thumbnail or None), emitted from the worker thread
    poseDone = Signal(int, object, object)

    def __init__(self, state, tasks, **kwargs):
        super().__init__(state, tasks, **kwargs)
        self.model = model = MeasurementModel()
        self._build()
        self.inputs = PoseListInputs(model, self.task, state, controls=self.controls, views=self.views,
                                     hooks=InputsHooks(say=self._set_status, measurements_path=self.measurements_path,
                                                       is_complete=self.is_complete, changed_inputs=self.changed_inputs,
                                                       teach_mode=lambda: self.teach_mode))
        self.run = MeasurementRun(model, self.task, state, self.controls, RunHooks(
            say=self._set_status, finish_autopilot=self._finish_autopilot,
            autopilot_running=lambda: self._autopilot_done is not None, post=self.poseDone.emit,
            measurements_path=self.measurements_path, teach_mode=lambda: self.teach_mode,
            is_complete=self.is_complete), parent=self)
        self.teaching = Teaching(model, self.task, state, controls=self.controls, panel=self.teach, views=self.views,
                                 splitter=self.splitter, table=self.table, hooks=TeachHooks(
                                     say=self._set_status, measurements_path=self.measurements_path,
                                     update_buttons=self._update_buttons, ready_status=self.inputs.ready_status,
                                     is_complete=self.is_complete))
        self.poseDone.connect(self.run.pose_reported)
        # the panels redraw from the model; the buttons and the wizard hear of every change of the rows
        for panel in (self.table, self.pair, self.summary):
            panel.follow(model)
        self.views.follow(model, lab=lambda: self.state.labs.current, selected=self.table.selected)
        model.on("rows", lambda _rows: self._update_buttons())
        for event in ("rows", "pose"):
            model.on(event, lambda _value: self.notify_complete())
        state.projectChanged.connect(self._context_changed)
        state.robotChanged.connect(self._context_changed)
        state.labChanged.connect(self.views.lab_changed)
        state.posesChanged.connect(lambda *_: self.inputs.changed(poses=True))
        state.markerChanged.connect(lambda *_: self.inputs.changed())
        state.stereoChanged.connect(lambda *_: self.inputs.changed())
        state.hardware.connectionChanged.connect(self.teaching.connection_changed)
        state.hardware.camerasChanged.connect(lambda *_: self.teaching.update_mode())
        self._context_changed()

    def _build(self) -> None:
        self.controls = RunControls(
            self.task.progress_row(), on_load=self.load_csv, on_start=self.start_run,
            folder=lambda: str(self.state.project.folder) if self.state.project is not None else "",
            on_pause=lambda on: self.run.set_paused(on), on_start_over=self.start_over,
            on_teach=lambda on: self.teaching.toggled(on))
        self.table = PoseTable()
        self.pair = PairView()
        upper = QSplitter(Qt.Orientation.Horizontal)
        upper.addWidget(self.table)
        upper.addWidget(self.pair)
        upper.setChildrenCollapsible(False)
        upper.setStretchFactor(0, 5)
        upper.setStretchFactor(1, 4)
        self.views = MeasurementViews()
        self.table.itemSelectionChanged.connect(self.views.highlight_selected)
        self.table.itemSelectionChanged.connect(lambda: self.teaching.show())
        self.splitter = QSplitter(Qt.Orientation.Vertical)
        self.splitter.addWidget(upper)
        self.splitter.addWidget(self.views)
        self.teach = TeachPanel(on_record=self.record_pose, on_typed=lambda text: self.teaching.typed_changed(text),
                                on_use_plan=lambda: self.teaching.use_plan())
        self.teach.setVisible(False)
        self.splitter.addWidget(self.teach)
        self.splitter.setChildrenCollapsible(False)
        self.splitter.setStretchFactor(0, 5)
        self.splitter.setStretchFactor(1, 5)
        self.splitter.setSizes([260, 300])
        self.summary = SummaryLabel()
        layout = QVBoxLayout(self)
        layout.setContentsMargins(0, 0, 0, 0)
        layout.setSpacing(6)
        layout.addWidget(self.controls)
        layout.addWidget(self.splitter, 1)
        layout.addWidget(self.summary)
        layout.addWidget(self.status)

    # -- what tests and the window read -------------------------------------------------------
    @property
    def poses(self) -> PoseList | None:
        return self.model.poses

    @property
    def rows(self) -> list[PoseRow]:
        return self.model.rows

    @property
    def n_min(self) -> int:
        return self.model.n_min

    @property
    def result(self):
        """The last run's MeasurementRunResult (None before a run, or after another project)."""
        return self.model.result

    @property
    def paused(self) -> bool:
        return self.run.paused

    @property
    def teach_mode(self) -> bool:
        return self.teaching.teach_mode

    def measurements_path(self) -> Path | None:
        return self.state.project.path(Output.MEASUREMENTS) if self.state.project is not None else None

    # -- what the technician asks for -----------------------------------------------------------
    def start_run(self) -> bool:
        """Start the run, or resume it after the last measured or rejected pose."""
        return self.run.start()

    def pause(self, on: bool = True) -> None:
        self.controls.show_options(replace(self.controls.options(), paused=bool(on)))

    def start_over(self, confirm: bool = True) -> bool:
        """Move measurements.csv and its rejects file aside (kept) to measure every pose again."""
        return self.run.start_over(confirm)

    def record_pose(self) -> bool:
        """Teach mode: record the pose shown where the robot is now; False when refused."""
        return self.teaching.record()

    def load_csv(self, path: str | Path) -> bool:
        """Measure the poses of this CSV (they go to the project's measurements.csv)."""
        return self.inputs.load_csv(path)

    def _context_changed(self, *_) -> None:
        """Another project or robot: nothing of a running task arrives, the project's poses again."""
        self.task.forget()
        self.run.forget()
        self.model.set_options(replace(self.model.options, loaded_csv=None))
        self.model.set_result(None)
        self.inputs.load()
        self.teaching.connection_changed()
        self.notify_complete()

    # -- WizardPage -------------------------------------------------------------------------
    def on_enter(self) -> None:
        if not self.task.busy:
            self.inputs.load()
        self.notify_complete()

    def is_complete(self) -> bool:
        return self.model.n_min > 0 and self.model.n_measured >= self.model.n_min and not self.changed_inputs()

    def changed_inputs(self) -> list[str]:
        """stereo.yaml or marker.npz changed since measurements.csv was measured with them."""
        if self.state.project is None:
            return []
        return changed_inputs(self.measurements_path(), measurement_inputs(self.state.project))

    def on_busy_changed(self) -> None:
        self._update_buttons()

    def on_progress(self, fraction: float, message: str) -> None:
        self.run.progress(message)

    def on_cancel_requested(self) -> None:
        self.run.cancel_requested()

    def autopilot(self, done) -> None:
        if self.state.project is None or self.state.robot is None:
            done(False, "no project or robot model (Setup step)")
            return
        if self.task.busy:
            done(False, "the page is busy")
            return
        self.inputs.load()
        self._autopilot_done = done
        self.run.autopilot_retried = False
        if self.model.poses is not None and not self.model.pending() and self.is_complete():
            self._finish_autopilot(True, self.model.done_message(self.measurements_path()))
            return
        if not self.start_run():
            self._finish_autopilot(False, self.status.text() or "the measurement could not start")

    # -- buttons -----------------------------------------------------------------------
    def _update_buttons(self) -> None:
        path, rows, busy = self.measurements_path(), self.model.rows, self.task.busy
        on_disk = path is not None and (path.exists() or rejects_path_for(path).exists())
        done_before = any(r.status != PENDING for r in rows)
        pending = bool(self.model.pending())
        self.controls.set_buttons(busy=busy, can_start=self.model.poses is not None and pending,
                                  resume=done_before and pending, can_start_over=done_before or on_disk,
                                  teach=self.teach_mode)
        self.controls.teach_check.setEnabled(not busy and (self.state.virtual or self.teaching.drivable()))
        self.teaching.show()
