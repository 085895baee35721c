"""Step 9, Compensation: the calibrated model turned into motion. Points typed by the technician
or read from a joint program are reached with the calibrated model (the corrected joints) and
with the nominal one (what the controller alone would do); the corrected program is written;
Go to point moves the project's robot there and the cameras measure where the marker landed;
the accuracy map measures a grid of targets reached both ways (app/jobs/compensation.py does the
work). On the virtual lab the lab's true robot moves; over a connected robot (a serial
controller, sim-robot) the robot moves after the safety checks of app/safety.py."""
from __future__ import annotations

from pathlib import Path

import numpy as np
from PySide6.QtWidgets import QFileDialog, QHBoxLayout, QVBoxLayout

from app.jobs import compensation as job
from app.jobs.measurement_hardware import capture_source
from app.pages.base import WizardPage
from app.pages.compensation.map_panel import MapPanel
from app.pages.compensation.points_panel import PointsPanel
from app.pages.compensation.points_table import PointsTable
from app.pages.measurement_inputs import project_marker, stereo_source
from app.pages.steps import Step
from app.safety import motion_refused
from core.compensation.accuracy_map_file import NAME as MAP_NAME, read_accuracy_map
from core.errors import RoboCalError
from core.project import Output
from widgets.wrapping_box import hold_height_for_width

AUTOPILOT_TARGETS = 8
MISSING = "No calibrated robot in the project (calibrated.json). Run the Identification step first."


class CompensationPage(WizardPage):
    step = Step.COMPENSATION

    def __init__(self, state, tasks, **kwargs):
        super().__init__(state, tasks, **kwargs)
        self.cell: job.Cell | None = None
        self._cell_key: tuple | None = None
        self.points: list[job.CompensatedPoint] = []
        self.map_run: job.MapRun | None = None
        self.amap = None
        self.panel = hold_height_for_width(PointsPanel())     # its rows wrap on a small screen
        self.panel.setMaximumWidth(340)      # narrower on a small screen: its rows wrap
        self.table = PointsTable()
        self.map_panel = hold_height_for_width(MapPanel())     # the plots and the wrapped summary
        self.panel.add_button.clicked.connect(lambda *_: self.add_point())
        self.panel.load_button.clicked.connect(lambda *_: self._choose_program())
        self.panel.clear_button.clicked.connect(lambda *_: self.clear_points())
        self.panel.write_button.clicked.connect(lambda *_: self._choose_output())
        self.panel.go_button.clicked.connect(lambda *_: self.go_to_point())
        self.map_panel.measure_button.clicked.connect(lambda *_: self.measure_map())

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
        self.refresh()

    # -- sources -------------------------------------------------------------------------
    def _file(self, name: str) -> Path | None:
        return self.state.project.folder / name if self.state.project is not None else None

    def calibrated_path(self) -> Path | None:
        return self.state.project.path(Output.CALIBRATED) if self.state.project is not None else None

    def measurements_path(self) -> Path | None:
        return self.state.project.path(Output.MEASUREMENTS) if self.state.project is not None else None

    def images(self):
        """(trained marker, stereo rectification) when the project has both, else None."""
        try:
            trained = project_marker(self.state)
        except RoboCalError:
            return None
        rect = stereo_source(self.state).rect
        return (trained, rect) if trained is not None and rect is not None else None

    @property
    def on_hardware(self) -> bool:
        """Motion goes to a connected robot (a serial controller) or the chosen cameras measure."""
        state = self.state
        return state.hardware.real_robot or state.hardware.cameras is not None or not state.virtual

    def _ready(self) -> bool:
        path = self.calibrated_path()
        return path is not None and path.is_file() and self.state.robot is not None

    def _load_cell(self) -> job.Cell | None:
        """The calibrated robot of the project (read again when calibrated.json changed)."""
        if not self._ready():
            self.cell = self._cell_key = None
            return None
        path = self.calibrated_path()
        meas = self.measurements_path()
        key = (str(path), path.stat().st_mtime_ns, id(self.state.robot), meas.is_file() and meas.stat().st_mtime_ns)
        if key != self._cell_key:
            if self.points:             # joints computed with another calibration: compute them again
                self.points = []
                self._show_points()
            self.cell, self._cell_key = job.load_cell(path, self.state.robot, meas), key
        return self.cell

    def _calibration_changed(self) -> None:
        self.task.forget()
        self.cell = self._cell_key = self.amap = self.map_run = None
        self.points = []
        self.table.show_points([], np.asarray)
        self.refresh()

    # -- page ----------------------------------------------------------------------------
    def on_enter(self) -> None:
        self.refresh()

    def is_complete(self) -> bool:
        return self.amap is not None and bool(self.amap.both.any()) and not self.amap.cancelled

    def refresh(self) -> None:
        if not self._ready():
            if not self.task.busy:
                self._set_status(MISSING if self.state.project is not None else
                                 "No project: choose one in the Setup step.", False)
        else:
            try:
                cell = self._load_cell()
            except RoboCalError as exc:
                self._set_status(f"✗ {exc.message}", False)
                cell = None
            saved = self._file(MAP_NAME)
            if cell is not None and self.amap is None and saved is not None and saved.is_file():
                try:
                    self.amap = read_accuracy_map(saved, cell.calibrated)
                    self.map_panel.show_map(self.amap, saved)
                except RoboCalError as exc:
                    self._set_status(f"✗ {exc.message}", False)
        self.on_busy_changed()
        self.notify_complete()

    def on_busy_changed(self) -> None:
        ready = self._ready()
        self.panel.set_enabled(self.task.busy, ready, bool(self.points), self.state.hardware.robot_connection is not None
                               or self.state.virtual)
        self.map_panel.measure_button.setEnabled(ready and not self.task.busy)

    def _q_file(self, q):
        return self.cell.calibrated.q_to_file(q) if self.cell is not None else np.rad2deg(q)

    def _show_points(self) -> None:
        self.table.show_points(self.points, self._q_file)
        self.on_busy_changed()

    # -- points --------------------------------------------------------------------------
    def _cell_or_say(self) -> job.Cell | None:
        try:
            cell = self._load_cell()
        except RoboCalError as exc:
            self._set_status(f"✗ {exc.message}", False)
            return None
        if cell is None:
            self._set_status(MISSING, False)
        return cell

    def add_point(self, xyz=None, frame: str | None = None) -> bool:
        """Compute the point typed (or `xyz`, mm, in `frame`: base, camera or fixture)."""
        cell = self._cell_or_say()
        if cell is None:
            return False
        frame = frame or self.panel.frame
        xyz = self.panel.point() if xyz is None else xyz
        try:
            where = job.frame_of(frame, self._file(job.FIXTURE_NAME))
        except RoboCalError as exc:
            self._set_status(f"✗ {exc.message}. {exc.hint or ''}".strip(), False)
            return False
        name = f"P{len(self.points) + 1}"
        return self.task.start(job.compensate_points, cell, [name], [xyz], where, on_done=self._points_added,
                          status=f"Computing the joints of {name}…")

    def _points_added(self, points) -> None:
        self.points.extend(points)
        self._show_points()
        self.table.selectRow(len(self.points) - 1)
        bad = [p for p in points if not p.reachable]
        if len(points) == 1:
            p = points[0]
            self._set_status(f"✗ {p.name}: {p.note}" if bad else
                             f"✓ {p.name}: corrected joints computed; predicted error {p.predicted_mm:.3f} mm "
                             f"(1σ from the calibration).", not bad)
        else:
            self._set_status(f"✓ {len(points)} points of the program computed"
                             + (f"; {len(bad)} cannot be reached with the calibrated model (see the notes)."
                                if bad else "."), not bad)

    def load_program(self, path, frame: str | None = None) -> bool:
        """A program file: Cartesian targets (name,x,y,z…, in `frame` or the frame chosen above)
        or a joints file taught with the nominal model; its points, corrected."""
        cell = self._cell_or_say()
        if cell is None:
            return False
        try:
            where = job.frame_of(frame or self.panel.frame, self._file(job.FIXTURE_NAME))
        except RoboCalError as exc:
            self._set_status(f"✗ {exc.message}. {exc.hint or ''}".strip(), False)
            return False
        self.points = []
        return self.task.start(job.compensate_program, cell, path, where, on_done=self._points_added,
                          status=f"Correcting the program {Path(path).name}…")

    def _choose_program(self) -> None:
        folder = str(self.state.project.folder) if self.state.project is not None else ""
        path, _ = QFileDialog.getOpenFileName(self, "Program: targets (name,x,y,z…) or joints (pose,q1…)", folder,
                                              "CSV files (*.csv);;All files (*)")
        if path:
            self.load_program(path)

    def clear_points(self) -> None:
        self.points = []
        self._show_points()
        self._set_status("Points cleared.", None)

    def write_program(self, path=None) -> Path | None:
        """Write the corrected joints (atomic) to `path` (default: the project's corrected_program.csv)."""
        if self.cell is None or not self.points:
            self._set_status("No points: type a point or load a program first.", False)
            return None
        path = Path(path) if path is not None else self._file(job.PROGRAM_NAME)
        try:
            written = job.write_corrected_program(path, self.cell, self.points)
        except RoboCalError as exc:
            self._set_status(f"✗ {exc.message}. {exc.hint or ''}".strip(), False)
            return None
        self._set_status(f"✓ Wrote {len(self.points)} corrected poses to {written.name} (pose,q1..q"
                         f"{self.cell.calibrated.dof}, degrees / mm).", True)
        return written

    def _choose_output(self) -> None:
        default = self._file(job.PROGRAM_NAME)
        path, _ = QFileDialog.getSaveFileName(self, "Corrected program", str(default or ""),
                                              "Joint files (*.csv)")
        if path:
            self.write_program(path)

    # -- moving and measuring ------------------------------------------------------------
    def _with_measure(self, Q, go) -> bool:
        """`go(measure, measured_by, lab)` once the robot may move to every row of Q: the virtual
        lab's true robot, or the connected robot with the cameras (or the lab's cameras rendering
        where it is)."""
        images = self.images()
        state = self.state
        if not self.on_hardware:
            def on_lab(lab):
                measure, where = job.lab_measure(lab, images, seed=int(state.seed))
                return go(measure, where, lab)
            return self.task.with_lab(on_lab)
        if images is None:
            self._set_status("Measuring on this robot needs the trained marker and the stereo calibration: run "
                             "the Stereo and Marker steps first.", False)
            return False
        if state.hardware.cameras is None and not state.virtual:
            self._set_status("No cameras: open the two cameras on the Setup page.", False)
            return False
        refused = motion_refused(self, state, Q)
        if refused:
            self._set_status(refused, False)
            return False
        driver = state.hardware.robot_connection

        def on_robot(lab):
            try:
                source = capture_source(state.hardware.cameras, lab=lab, driver=driver, seed=int(state.seed))
            except RoboCalError as exc:
                self._set_status(f"✗ {exc.message}", False)
                return False
            measure, where = job.robot_measure(driver, source, images, rendered=state.hardware.cameras is None)
            return go(measure, where, lab)
        return self.task.with_lab(on_robot) if state.hardware.cameras is None else on_robot(None)

    def go_to_point(self, row: int | None = None, *, nominal: bool | None = None) -> bool:
        """Move to the selected point with the calibrated model (or, `nominal` / the check box,
        with the nominal one) and measure the marker."""
        row = self.table.currentRow() if row is None else row
        nominal = self.panel.nominal_check.isChecked() if nominal is None else nominal
        if not 0 <= row < len(self.points):
            self._set_status("Select a point in the table first.", False)
            return False
        point = self.points[row]
        q = point.joints(nominal)
        model = "nominal" if nominal else "calibrated"
        if not np.all(np.isfinite(q)):
            self._set_status(f"✗ {point.name} cannot be reached with the {model} model: {point.note}", False)
            return False

        def go(measure, where, lab):
            return self.task.start(job.go_to_point, point, measure, where, nominal=nominal,
                              on_done=lambda p: self._landed(row, p, nominal),
                              status=f"Moving to {point.name} with the {model} model… Esc stops the robot.")
        return self._with_measure(q[None, :], go)

    def _landed(self, row: int, point: job.CompensatedPoint, nominal: bool) -> None:
        self.points[row] = point
        self._show_points()
        self.table.selectRow(row)
        model = "nominal" if nominal else "calibrated"
        if not np.isfinite(point.error_mm(nominal)):
            self._set_status(f"⚠ {point.name}: the robot moved but the cameras did not find the marker "
                             f"({point.measured_by}).", False)
            return
        predicted = "" if nominal else f" (predicted {point.predicted_mm:.3f} mm, 1σ)"
        self._set_status(f"✓ {point.name}, {model} model: the marker landed {point.error_mm(nominal):.3f} mm from "
                         f"the target{predicted}; measured: {point.measured_by}.", True)

    def measure_map(self) -> bool:
        """The before/after accuracy map on the project's robot, written to accuracy_map.json."""
        cell = self._cell_or_say()
        if cell is None:
            return False
        folder, measurements, count = self.state.project.folder, self.measurements_path(), self.map_panel.count_spin.value()

        def go(measure, where, lab):
            keep = (lambda Q: lab.visibility(Q).visible) if lab is not None else None
            return self.task.start(job.measure_accuracy_map, cell, measurements, measure, where, folder, count=count,
                              keep=keep, on_done=self._map_measured,
                              status=f"Measuring the accuracy map ({count} targets, each reached twice)… "
                                     "Esc stops the robot.")
        # the grid's joints are checked by the driver before every motion
        return self._with_measure(np.zeros((0, cell.calibrated.dof)), go)

    def _map_measured(self, run: job.MapRun) -> None:
        self.map_run, self.amap = run, run.amap
        self.map_panel.show_map(run.amap, run.path)
        ok = bool(run.amap.both.any()) and not run.amap.cancelled
        self._set_status(("✓ " if ok else "⚠ ") + run.amap.summary()
                         + (f" Wrote {run.path.name}." if run.path is not None else " Nothing written."), ok)
        self.notify_complete()
        self._finish_autopilot(ok, "" if ok else run.amap.summary())

    def autopilot(self, done) -> None:
        """The classroom run: a small accuracy map (each target is rendered and located twice)."""
        self._autopilot_done = done
        self.map_panel.count_spin.setValue(AUTOPILOT_TARGETS)
        if not self.measure_map():
            self._finish_autopilot(False, self.status.text())
