"""Step 8, Check: measure the marker at a few check poses, compare it with the calibrated model's
prediction against limits from the calibration's own uncertainty, append every point to the
project's check log (checks.csv), draw the control charts, say in plain words what changed, and
re-identify it from a few proposed poses (app/jobs/check.py does the work).
With several tools, the tool mounted is chosen here, and a newly mounted tool is identified from
its own few poses (app/jobs/tool.py).

Every check measures on the project's cell and says which: in a virtual-lab project the lab (with
a change to simulate); in a real-cell project the connected robot is driven to each pose (safety
as on the Measurement page: limits checked before sending, the first motion confirmed, Esc stops)
and the marker located in the pairs of the project's cameras (app/jobs/cell_check.py). A real-cell
project never measures the lab: with no robot or cameras connected the page says so and does
nothing. A robot fault ends a check (and the schedule) after the points measured, which stay in
the log."""
from __future__ import annotations

from pathlib import Path

from PySide6.QtCore import Qt, QTimer
from PySide6.QtWidgets import QFrame, QHBoxLayout, QScrollArea, QStyle, QVBoxLayout, QWidget

from app.jobs import cell_check, cell_teach
from app.jobs import check as job
from app.jobs import fixture as fixture_job
from app.jobs import tool as tool_job
from app.pages.base import WizardPage
from app.pages.check.cell import CellMixin
from app.pages.check.controls_panel import CheckControls
from app.pages.check.fixture_panel import FixturePanel
from app.pages.check.results_panel import CheckResults
from app.pages.check.teach import TeachMixin
from app.pages.check.teach_panel import TeachCheckPanel
from app.pages.measurement_inputs import project_marker, stereo_source
from app.pages.steps import Step
from core.errors import RoboCalError
from core.monitoring.log import CheckLog, read_check_log
from core.project import Output

LOG_NAME = "checks.csv"
MISSING = "No calibrated robot in the project (calibrated.json). Run the Identification step first."
NO_PROJECT = "No project: choose one in the Setup step."
LEFT_WIDTH = 320          # px, the column of controls


def short_verdict(result) -> str:
    """One line: within or out of limits, the RMS error against its limit, how many poses are out."""
    if result.cancelled or not result.points:
        return result.verdict()
    out = sum(not p.within for p in result.points)
    text = (f"Check {'within limits' if result.within else 'OUT OF LIMITS'}: RMS error {result.rms_mm:.3f} mm "
            f"(limit {result.rms_limit_mm:.3f} mm); {out} of {len(result.points)} poses beyond their limits")
    return text + (f"; {len(result.missing)} not measured." if result.missing else ".")


class CheckPage(CellMixin, TeachMixin, WizardPage):
    step = Step.CHECK

    def __init__(self, state, tasks, **kwargs):
        super().__init__(state, tasks, **kwargs)
        self.cell: job.CheckSetup | None = None
        self._cell_key: tuple | None = None     # (calibrated file, its mtime, pose count) of `cell`
        self.result = None
        self.diagnosis = None
        self.update = None
        self.tool_update: tool_job.ToolUpdate | None = None
        self.log: CheckLog | None = None
        self._images = None                    # how the last check measured (see `images`)
        self._where = ""                       # where the running check measures, in words
        self.taught: dict[int, cell_teach.TaughtCheckPose] = {}     # teach mode: check pose -> recorded

        self.controls = CheckControls()
        self.results = CheckResults()
        self.fixture = FixturePanel()
        self.fixture.locate_button.clicked.connect(lambda *_: self.locate_fixture())
        self.fixture_run = None
        self.teach = TeachCheckPanel()
        self.teach.record_button.clicked.connect(lambda *_: self.record_pose())
        self.teach.check_button.clicked.connect(lambda *_: self.run_check())
        self.controls.run_button.clicked.connect(lambda *_: self.run_check())
        self.controls.choose_button.clicked.connect(lambda *_: self.choose_poses())
        self.controls.schedule_check.toggled.connect(lambda *_: self._schedule_changed())
        self.controls.minutes_spin.valueChanged.connect(lambda *_: self._schedule_changed())
        self.results.reidentify_button.clicked.connect(lambda *_: self.reidentify())
        self.controls.identify_tool_button.clicked.connect(lambda *_: self.identify_tool())
        self.schedule_timer = QTimer(self)
        self.schedule_timer.timeout.connect(self._scheduled)

        body = QHBoxLayout()
        body.addWidget(self._left_column(), 0)
        body.addWidget(self.results, 1)
        layout = QVBoxLayout(self)
        layout.setContentsMargins(0, 0, 0, 0)
        layout.addLayout(body, 1)
        layout.addWidget(self.task.progress_row())
        layout.addWidget(self.status)

        state.projectChanged.connect(lambda *_: self._calibration_changed())
        state.cellChanged.connect(lambda *_: self._calibration_changed())
        state.hardware.connectionChanged.connect(lambda *_: self.refresh())
        state.hardware.camerasChanged.connect(lambda *_: self.refresh())
        state.robotChanged.connect(lambda *_: self._calibration_changed())
        state.outputSaved.connect(lambda key: self.refresh() if key == "calibrated" else None)
        self.refresh()

    def _left_column(self) -> QScrollArea:
        """The controls, teach and fixture panels in a column of fixed width that scrolls on its
        own when taller than the page (a small screen), beside the results."""
        column = QWidget()
        column.setFixedWidth(LEFT_WIDTH)
        left = QVBoxLayout(column)
        left.setContentsMargins(0, 0, 0, 0)
        left.addWidget(self.controls, 1)
        left.addWidget(self.teach)
        left.addWidget(self.fixture)
        scroll = QScrollArea()
        scroll.setObjectName("checkControlsScroll")
        scroll.setWidgetResizable(True)
        scroll.setFrameShape(QFrame.Shape.NoFrame)
        scroll.setHorizontalScrollBarPolicy(Qt.ScrollBarPolicy.ScrollBarAlwaysOff)
        scroll.setWidget(column)
        scroll.setFixedWidth(LEFT_WIDTH + scroll.style().pixelMetric(QStyle.PixelMetric.PM_ScrollBarExtent) + 2)
        return scroll

    # -- sources -------------------------------------------------------------------------
    def calibrated_path(self) -> Path | None:
        return self.state.project.path(Output.CALIBRATED) if self.state.project is not None else None

    def log_path(self) -> Path | None:
        return self.state.project.folder / LOG_NAME if self.state.project is not None else None

    def images(self):
        """(trained marker, stereo rectification) when the project has both: checks then measure
        through rendered images, as the calibration did; None: the lab's ideal measurements."""
        try:
            trained = project_marker(self.state)
        except RoboCalError:
            return None
        rect = stereo_source(self.state).rect
        return (trained, rect) if trained is not None and rect is not None else None

    def _measured_by(self, images) -> str:
        return ("measured on the virtual lab, through its cameras' images (trained marker, stereo calibration)"
                if images is not None else
                "measured on the virtual lab, ideal measurements (no trained marker or stereo calibration in the "
                "project)")

    def _ready(self) -> bool:
        path = self.calibrated_path()
        return path is not None and path.is_file()

    def _key(self) -> tuple:
        path = self.calibrated_path()
        return (str(path), path.stat().st_mtime_ns, self.controls.count_spin.value(), self.controls.tool())

    def _calibration_changed(self) -> None:
        self.task.forget()
        self.cell = self._cell_key = self.result = self.diagnosis = self.update = None
        self.taught, self._measure = {}, None
        self.controls.poses_list.clear()
        self.results.show_verdict("No check yet.", None)
        self.results.show_diagnosis("", False)
        self.refresh()

    # -- page ----------------------------------------------------------------------------
    def on_enter(self) -> None:
        self.refresh()

    def is_complete(self) -> bool:
        return self.log is not None and any(c.finished for c in self.log.checks)

    def refresh(self) -> None:
        """Read the check log and the calibration's presence, and draw them."""
        self.controls.show_cell(self.state.cell)
        if self.state.robot is not None:
            self.controls.set_dof(self.state.robot.dof)
            self.controls.set_tools(self.state.robot.tool_names())
        self.log = None
        path = self.log_path()
        if path is not None and path.is_file():
            try:
                self.log = read_check_log(path)
            except RoboCalError as exc:
                self._set_status(f"✗ {exc.message}", False)
        self.results.show_log(self.log)
        if not self._ready() and not self.task.busy:
            self._set_status(MISSING if self.state.project is not None else NO_PROJECT, False)
        elif not self.state.virtual and not self.task.busy and self.result is None:
            problem = self.cell_problem()
            self._set_status(f"This project measures on {self.state.cell}. "
                             + (f"Nothing can be measured: {problem}." if problem else "Ready to check."),
                             None if problem is None else False)
        elif not self.task.busy and self.status.text() in ("", MISSING, NO_PROJECT):     # words of before
            self._set_status(f"Ready to check the calibrated robot ({self.calibrated_path().name}) on the "
                             "virtual lab.", None)
        self.on_busy_changed()
        self.notify_complete()

    def on_busy_changed(self) -> None:
        self.controls.set_enabled(self.task.busy, self._ready(), self.state.virtual)
        can = self.diagnosis is not None and self.diagnosis.explained and bool(self.diagnosis.parameters)
        self.results.reidentify_button.setEnabled(can and not self.task.busy)
        self.fixture.set_enabled(self.task.busy, self._ready())
        self.fixture.set_virtual(self.state.virtual)
        teach = self.teach_mode
        self.teach.setVisible(teach)
        self.controls.allow_schedule(self._schedule_blocked(), self.task.busy)
        self.controls.identify_tool_button.setEnabled(self.controls.identify_tool_button.isEnabled() and not teach)
        if teach:
            self._show_next_pose()

    def _schedule_blocked(self) -> str | None:
        """Why checks cannot run on a schedule here (None: they can)."""
        if self.state.project is None:
            return "there is no project: choose one on the Setup page"
        if not self._ready():
            return "the project has no calibrated robot (calibrated.json): run the Identification step first"
        if self.teach_mode:
            return "in teach mode the robot is brought to every check pose by hand"
        if not self.state.virtual:
            problem = self.cell_problem()
            if problem is not None:
                return f"nothing can be measured: {problem}"
        return None

    # -- actions -------------------------------------------------------------------------
    def _cell(self) -> job.CheckSetup | None:
        """The current check setup, or None when the calibration file or the pose count changed."""
        return self.cell if self.cell is not None and self._cell_key == self._key() else None

    def choose_poses(self) -> bool:
        """Choose the check poses now (they are chosen with the first check otherwise)."""
        if not self._can_run():
            return False
        key, path = self._key(), self.calibrated_path()
        if not self.state.virtual:
            return self.task.start(cell_check.setup_cell, path, self._cell_options(), count=key[2], tool=key[3],
                              on_done=lambda cell: self._take_cell(cell, key),
                              status="Choosing check poses for the cell's cameras…")
        return self.task.start_with_lab(self._setup_job, path, self.controls.count_spin.value(), self.controls.tool(),
                                   on_done=lambda cell: self._take_cell(cell, key),
                                   status="Choosing check poses…")

    @staticmethod
    def _setup_job(path, count, tool, *, lab, progress=None, cancelled=None):
        from app.lab import lab_options
        return job.setup(path, lab_options=lab_options(lab), count=count, sigma_mm=job.weighted_sigma_mm(path),
                         tool=tool, progress=progress, cancelled=cancelled)

    def _take_cell(self, cell: job.CheckSetup, key: tuple) -> None:
        if cell is not self.cell:
            self.taught = {}
        self.cell, self._cell_key = cell, key
        self.controls.show_poses(cell.model.q_to_file(cell.Q))
        self._set_status(f"✓ {len(cell.Q)} check poses chosen; limits from the calibration's uncertainty "
                         f"(σ {cell.unc.sigma_mm:.3f} mm, false alarms {100 * cell.limits.alpha:g} %).", True)
        self.on_busy_changed()

    def _can_run(self) -> bool:
        if not self._ready():
            self._set_status(MISSING, False)
            self._finish_autopilot(False, MISSING)
            return False
        if not self.state.virtual:
            problem = self.cell_problem()
            if problem is not None:
                self._set_status(f"Nothing measured: {problem}. (This project measures on {self.state.cell}; "
                                 "never on the virtual lab.)", False)
                self._finish_autopilot(False, problem)
                return False
        return True

    def run_check(self) -> bool:
        """One check at every check pose (the poses are chosen first when needed)."""
        if not self._can_run():
            return False
        if not self.state.virtual:
            return self._check_cell()
        key, images = self._key(), self.images()
        self._images = images
        self._where = self._measured_by(images)
        return self.task.start_with_lab(job.check_project, self.calibrated_path(), on_done=lambda r: self._checked(r, key),
                                   cell=self._cell(), count=key[2], change=self.controls.change_spec(),
                                   images=images, log=self.log_path(), seed=self._seed(), tool=key[3],
                                   status=f"Checking: {self._measured_by(images)}…")

    def _seed(self) -> int:
        """A new noise seed for every check, also after a restart (the log's length)."""
        return 1 + len(self.log.checks) if self.log is not None else 1

    def _checked(self, value, key: tuple) -> None:
        cell, self.result, self.diagnosis = value
        self.update = None
        if cell is not self.cell:
            self._take_cell(cell, key)
        self._show_result(self.result, self.diagnosis)
        self.refresh()
        fault = self._fault_words()
        payload = job.payload_comparison(self.controls.payload_kg(), cell.model)[0]
        self._set_status(("✓ " if self.result.within and not fault else "⚠ ") + short_verdict(self.result)
                         + " Points " + self._where + "." + fault + (" " + payload if payload else ""),
                         self.result.within and not fault)
        self._finish_autopilot(bool(self.result.points), "" if self.result.points else self.result.verdict())

    def _show_result(self, result, diagnosis) -> None:
        self.results.show_verdict(short_verdict(result), result.within, result.verdict())
        if diagnosis is None:
            self.results.show_diagnosis("The marker is where the calibrated model puts it." if result.within
                                        else "", False)
        else:
            self.results.show_diagnosis(diagnosis.text, diagnosis.explained and bool(diagnosis.parameters))
        self.on_busy_changed()

    def reidentify(self) -> bool:
        """Re-identify what the diagnosis found and check the updated robot."""
        if self.diagnosis is None or self.cell is None or not self._can_run():
            return False
        if self.teach_mode:
            self._set_status("In teach mode RoboCal cannot drive the proposed poses: measure them with the "
                             "Measurement step's teach mode, then run robocal reidentify with that file.", False)
            return False
        if not self.state.virtual:
            measure = self._cell_measure()
            if measure is None:
                return False
            return self.task.start(cell_check.reidentify_cell, self.cell, self.result, self.diagnosis, measure,
                              self.calibrated_path(), self._cell_options(), log=self.log_path(),
                              on_done=self._reidentified,
                              status=f"Re-identifying from the proposed poses, {self._where}… Esc stops the robot.")
        from app.lab import lab_options
        self._where = self._measured_by(self.images())

        def go(lab):
            return self.task.start(job.reidentify_on_lab, self.cell, self.result, self.diagnosis, lab,
                              self.controls.change_spec(), self.calibrated_path(), images=self.images(),
                              lab_options=lab_options(lab), log=self.log_path(), seed=self._seed(),
                              on_done=self._reidentified, status="Re-identifying from the proposed poses…")
        return self.task.with_lab(go, status="Re-identifying…")

    def _reidentified(self, update: job.Update) -> None:
        self.update = update
        # calibrated.json now holds a newer calibration than this session's identification:
        # Export and the report read the file from here on
        self.state.set_identification(None)
        self.cell, self._cell_key = update.cell, self._key()
        self.result, self.diagnosis = update.after, None
        self._show_result(update.after, None)
        self.refresh()
        changed = ", ".join(update.reidentification.changed)
        self._set_status(f"✓ Re-identified {changed} from {len(update.proposed)} proposed "
                         f"pose{'s' if len(update.proposed) != 1 else ''} and the check, "
                         f"{self._where}; wrote {update.path.name} (the previous one is kept in history/). Check "
                         f"of the updated robot: {short_verdict(update.after)}" + self._fault_words(),
                         update.after.within and not update.after.cancelled)

    # -- fixture -------------------------------------------------------------------------
    def locate_fixture(self) -> bool:
        """Locate the lab's fixture, or the chosen description's from its pairs folder, through the
        calibration; write fixture_pose.json and fixture.urdf to the project."""
        if not self._ready():
            self._set_status(MISSING, False)
            return False
        images = self.images()
        if images is None:
            self._set_status("Locating a fixture needs the trained marker and the stereo calibration: run the "
                             "Stereo and Marker steps first.", False)
            return False
        folder, calibrated = self.state.project.folder, self.calibrated_path()
        if self.fixture.source == "lab":
            if not self.state.virtual:
                self._set_status("The lab's fixture needs a virtual-lab project; choose image pairs.", False)
                return False
            return self.task.start_with_lab(fixture_job.locate_on_lab, calibrated, *images, folder,
                                       seed=self._seed(), on_done=self._fixture_located,
                                       status="Locating the lab's fixture…")
        if not self.fixture.description_path or not self.fixture.pairs_folder:
            self._set_status("Choose the fixture description and the folder of image pairs first.", False)
            return False
        return self.task.start(fixture_job.locate_from_folder, calibrated, *images, self.fixture.description_path,
                          self.fixture.pairs_folder, folder, on_done=self._fixture_located,
                          status="Locating the fixture…")

    def _fixture_located(self, run) -> None:
        self.fixture_run = run
        self.fixture.show_run(run)
        f = run.result.frame
        self._set_status(f"✓ Fixture located ({f.method}, RMS residual {f.rms_mm:.3f} mm): wrote "
                         f"{run.pose_path.name} and {run.urdf_path.name}.", True)

    def identify_tool(self) -> bool:
        """Identify the tool chosen as mounted from its proposed poses on the virtual lab, and
        replace calibrated.json (the previous one kept in history/)."""
        tool = self.controls.tool()
        if tool is None or not self._can_run():
            return False
        if not self.state.virtual:
            measure = self._cell_measure()
            if measure is None:
                return False
            return self.task.start(cell_check.identify_tool_cell, self.calibrated_path(), tool, measure,
                              self._cell_options(), on_done=self._tool_identified,
                              status=f"Identifying the tool '{tool}' from its proposed poses, {self._where}… Esc "
                                     "stops the robot.")
        self._where = self._measured_by(self.images())
        return self.task.start_with_lab(tool_job.identify_on_lab, self.calibrated_path(), tool,
                                   change=self.controls.change_spec(), images=self.images(), seed=self._seed(),
                                   on_done=self._tool_identified,
                                   status=f"Identifying the tool '{tool}' from its proposed poses…")

    def _tool_identified(self, update: tool_job.ToolUpdate) -> None:
        self.state.set_identification(None)     # Export and the report read the updated file
        self.cell = self._cell_key = self.result = self.diagnosis = None
        self.tool_update = update
        self.refresh()
        self._set_status(f"✓ {update.identification.text()} Points {self._where}. Wrote {update.path.name} (the "
                         f"previous one is kept in history/).", True)

    # -- schedule ------------------------------------------------------------------------
    def _schedule_changed(self) -> None:
        if self.controls.schedule_check.isChecked():
            self.schedule_timer.start(self.controls.minutes_spin.value() * 60_000)
        else:
            self.schedule_timer.stop()

    def _scheduled(self) -> None:
        if not self.task.busy:
            self.run_check()

    def autopilot(self, done) -> None:
        """One check on the virtual lab, no change simulated."""
        self._autopilot_done = done
        self.controls.choose_change("", 1.5)
        self.run_check()
