"""Step 9, Compensation: the calibrated model turned into motion. Points typed by the technician
or read from a joint program are reached with the calibrated model (the corrected joints) and
with the nominal one (what the controller alone would do); the corrected program is written;
Go to point moves the project's robot there and the cameras measure where the marker landed;
the accuracy map measures a grid of targets reached both ways (app/jobs/compensation.py does the
work). On the virtual lab the lab's true robot moves; over a connected robot (a serial
controller, sim-robot) the robot moves after the safety checks of app/safety.py (motion.py).

The page is the controller: the panels say what was chosen (CompensationOptions), a job computes
or measures, the model (model.py) keeps the points and the map and the panels draw from it."""
from __future__ import annotations

from pathlib import Path

import numpy as np
from PySide6.QtWidgets import QHBoxLayout, QVBoxLayout

from app.jobs import compensation as job
from app.pages.base import WizardPage
from app.pages.compensation import texts
from app.pages.compensation.map_panel import MapPanel
from app.pages.compensation.model import CompensationModel, CompensationOptions, MeasuredMap
from app.pages.compensation.motion import CellMotion
from app.pages.compensation.points_panel import PointsPanel
from app.pages.compensation.points_table import PointsTable
from app.pages.compensation.texts import MISSING
from app.pages.steps import Step
from core.compensation.accuracy_map_file import NAME as MAP_NAME, read_accuracy_map
from core.errors import RoboCalError
from core.project import Output
from widgets.wrapping_box import hold_height_for_width

__all__ = ["AUTOPILOT_TARGETS", "MISSING", "CompensationPage"]

AUTOPILOT_TARGETS = 8


class CompensationPage(WizardPage):
    step = Step.COMPENSATION

    def __init__(self, state, tasks, **kwargs):
        super().__init__(state, tasks, **kwargs)
        self.model = CompensationModel()
        self.motion = CellMotion(self, state, self.task, self._set_status)
        self.panel = hold_height_for_width(PointsPanel(lambda: state.project.folder if state.project else None))
        self.panel.setMaximumWidth(340)      # narrower on a small screen: its rows wrap
        self.table = PointsTable()
        self.map_panel = hold_height_for_width(MapPanel())     # the plots and the wrapped summary
        self.panel.add_button.clicked.connect(lambda *_: self.add_point())
        self.panel.programChosen.connect(lambda path: self.load_program(path))
        self.panel.clear_button.clicked.connect(lambda *_: self.clear_points())
        self.panel.outputChosen.connect(lambda path: self.write_program(path))
        self.panel.go_button.clicked.connect(lambda *_: self.go_to_point())
        self.map_panel.measure_button.clicked.connect(lambda *_: self.measure_map())
        self.model.on("points", lambda row: self.table.show_points(self.model.points, self.model.q_file, row))
        self.model.on("points", lambda _row: self.on_busy_changed())
        self.model.on("result", self.map_panel.show_map)

        # the points and their table side by side, the accuracy map below them at the page's whole
        # width (its two plots keep their titles on a small screen, where the page scrolls instead)
        points = QHBoxLayout()
        points.addWidget(self.panel)
        points.addWidget(self.table, 1)
        layout = QVBoxLayout(self)
        layout.setContentsMargins(0, 0, 0, 0)
        layout.addLayout(points)
        layout.addWidget(self.map_panel, 1)
        layout.addWidget(self.task.progress_row())
        layout.addWidget(self.status)
        state.projectChanged.connect(lambda *_: self._calibration_changed())
        state.robotChanged.connect(lambda *_: self._calibration_changed())
        state.hardware.connectionChanged.connect(lambda *_: self.on_busy_changed())
        self.on_enter()

    # -- what the page holds (the model's) -------------------------------------------------
    @property
    def points(self) -> list[job.CompensatedPoint]:
        return self.model.points

    @property
    def cell(self) -> job.Cell | None:
        return self.model.cell

    @property
    def amap(self):
        """The accuracy map measured or read back (None: none yet)."""
        return self.model.result.amap if self.model.result is not None else None

    @property
    def on_hardware(self) -> bool:
        """Motion goes to a connected robot (a serial controller) or the chosen cameras measure."""
        return self.motion.on_hardware

    def _options(self) -> CompensationOptions:
        """What the panels say was chosen, kept in the model."""
        self.model.set_options(CompensationOptions(self.panel.options(), self.map_panel.options()))
        return self.model.options

    def _calibration_changed(self) -> None:
        self.task.forget()
        self.model.forget()
        self.on_enter()

    def _cell_or_say(self, frame: str | None = None) -> tuple[job.Cell, object] | None:
        """(the calibrated cell, where the points of `frame` are — None without a frame), or None
        when either is missing (the status line says why)."""
        try:
            cell = self.model.load_cell(self.state.project, self.state.robot)
        except RoboCalError as exc:
            self._set_status(f"✗ {exc.message}", False)
            return None
        if cell is None:
            self._set_status(MISSING, False)
            return None
        if frame is None:
            return cell, None
        try:
            return cell, job.frame_of(frame, self.state.project.folder / job.FIXTURE_NAME)
        except RoboCalError as exc:
            self._set_status(f"✗ {exc.message}. {exc.hint or ''}".strip(), False)
            return None

    # -- page ----------------------------------------------------------------------------
    def on_enter(self) -> None:
        """Read the calibrated robot again when it changed, and the saved accuracy map once."""
        project = self.state.project
        if not self.model.ready(project, self.state.robot):
            if not self.task.busy:
                self._set_status(MISSING if project is not None else
                                 "No project: choose one in the Setup step.", False)
        else:
            inputs = self._cell_or_say()
            saved = project.folder / MAP_NAME
            if inputs is not None and self.model.result is None and saved.is_file():
                try:
                    self.model.set_result(MeasuredMap(read_accuracy_map(saved, inputs[0].calibrated), saved))
                except RoboCalError as exc:
                    self._set_status(f"✗ {exc.message}", False)
        self.on_busy_changed()
        self.notify_complete()

    def is_complete(self) -> bool:
        amap = self.amap
        return amap is not None and bool(amap.both.any()) and not amap.cancelled

    def on_busy_changed(self) -> None:
        ready = self.model.ready(self.state.project, self.state.robot)
        self.panel.set_enabled(self.task.busy, ready, bool(self.model.points),
                               self.state.hardware.robot_connection is not None or self.state.virtual)
        self.map_panel.measure_button.setEnabled(ready and not self.task.busy)

    # -- points --------------------------------------------------------------------------
    def add_point(self, xyz=None, frame: str | None = None) -> bool:
        """Compute the point typed (or `xyz`, mm, in `frame`: base, camera or fixture)."""
        typed = self._options().points
        inputs = self._cell_or_say(frame or typed.frame)
        if inputs is None:
            return False
        name = f"P{len(self.model.points) + 1}"
        return self.task.start(job.compensate_points, inputs[0], [name], [typed.point if xyz is None else xyz],
                               inputs[1], status=f"Computing the joints of {name}…",
                               on_done=lambda points: self._set_status(*texts.points_added(self.model.add_points(points))))

    def load_program(self, path, frame: str | None = None) -> bool:
        """A program file: Cartesian targets (name,x,y,z…, in `frame` or the frame chosen above)
        or a joints file taught with the nominal model; its points, corrected."""
        inputs = self._cell_or_say(frame or self._options().points.frame)
        if inputs is None:
            return False
        self.model.points = []
        return self.task.start(job.compensate_program, inputs[0], path, inputs[1],
                               status=f"Correcting the program {Path(path).name}…",
                               on_done=lambda points: self._set_status(*texts.points_added(self.model.add_points(points))))

    def clear_points(self) -> None:
        self.model.clear_points()
        self._set_status("Points cleared.", None)

    def write_program(self, path=None) -> Path | None:
        """Write the corrected joints (atomic) to `path` (default: the project's corrected_program.csv)."""
        cell, points = self.model.cell, self.model.points
        if cell is None or not points:
            self._set_status("No points: type a point or load a program first.", False)
            return None
        path = Path(path) if path is not None else self.state.project.folder / job.PROGRAM_NAME
        try:
            written = job.write_corrected_program(path, cell, points)
        except RoboCalError as exc:
            self._set_status(f"✗ {exc.message}. {exc.hint or ''}".strip(), False)
            return None
        self._set_status(f"✓ Wrote {len(points)} corrected poses to {written.name} (pose,q1..q"
                         f"{cell.calibrated.dof}, degrees / mm).", True)
        return written

    # -- moving and measuring ------------------------------------------------------------
    def go_to_point(self, row: int | None = None, *, nominal: bool | None = None) -> bool:
        """Move to the selected point with the calibrated model (or, `nominal` / the check box,
        with the nominal one) and measure the marker."""
        row = self.table.currentRow() if row is None else row
        nominal = self._options().points.nominal if nominal is None else nominal
        if not 0 <= row < len(self.model.points):
            self._set_status("Select a point in the table first.", False)
            return False
        point = self.model.points[row]
        q = point.joints(nominal)
        model = "nominal" if nominal else "calibrated"
        if not np.all(np.isfinite(q)):
            self._set_status(f"✗ {point.name} cannot be reached with the {model} model: {point.note}", False)
            return False

        def go(measure, where, lab):
            return self.task.start(job.go_to_point, point, measure, where, nominal=nominal,
                                   on_done=lambda p: self._set_status(*texts.landed(self.model.replace_point(row, p),
                                                                                    nominal)),
                                   status=f"Moving to {point.name} with the {model} model… Esc stops the robot.")
        return self.motion.with_measure(q[None, :], go)

    def measure_map(self) -> bool:
        """The before/after accuracy map on the project's robot, written to accuracy_map.json."""
        inputs = self._cell_or_say()
        if inputs is None:
            return False
        cell, count = inputs[0], self._options().map_targets
        folder, measurements = self.state.project.folder, self.state.project.path(Output.MEASUREMENTS)

        def go(measure, where, lab):
            keep = (lambda Q: lab.visibility(Q).visible) if lab is not None else None
            return self.task.start(job.measure_accuracy_map, cell, measurements, measure, where, folder, count=count,
                                   keep=keep, on_done=self._map_measured,
                                   status=f"Measuring the accuracy map ({count} targets, each reached twice)… "
                                          "Esc stops the robot.")
        # the grid's joints are checked by the driver before every motion
        return self.motion.with_measure(np.zeros((0, cell.calibrated.dof)), go)

    def _map_measured(self, run: job.MapRun) -> None:
        self.model.set_result(MeasuredMap(run.amap, run.path))
        text, ok = texts.map_measured(run)
        self._set_status(text, ok)
        self.notify_complete()
        self._finish_autopilot(ok, "" if ok else run.amap.summary())

    def autopilot(self, done) -> None:
        """The classroom run: a small accuracy map (each target is rendered and located twice)."""
        self._autopilot_done = done
        self.map_panel.show_options(AUTOPILOT_TARGETS)
        if not self.measure_map():
            self._finish_autopilot(False, self.status.text())
