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
the log.

The page is a small controller: the controls panel's options go into the model (model.py), the
runs (runs.py: on the lab, or on the real cell through cell.py and teach.py) put what the jobs
return into the model, and the panels draw from the model's events.
"""
from __future__ import annotations

from pathlib import Path

from PySide6.QtCore import Qt
from PySide6.QtWidgets import QFrame, QHBoxLayout, QScrollArea, QStyle, QVBoxLayout, QWidget

from app.pages.base import WizardPage
from app.pages.check.cell import RealCell
from app.pages.check.controls_panel import CheckControls
from app.pages.check.fixture import FixtureLocator
from app.pages.check.fixture_panel import FixturePanel
from app.pages.check.inputs import CheckInputs
from app.pages.check.model import CheckModel
from app.pages.check.results_panel import CheckResults
from app.pages.check.runs import CheckRuns
from app.pages.check.schedule import CheckSchedule
from app.pages.check.teach import TeachPoses
from app.pages.check.teach_panel import TeachCheckPanel
from app.pages.check.texts import MISSING, NO_PROJECT
from app.pages.steps import Step
from core.errors import RoboCalError
from core.monitoring.log import read_check_log

LEFT_WIDTH = 320          # px, the column of controls


def left_column(*panels: QWidget) -> QScrollArea:
    """The panels (the first stretching) in a column of fixed width that scrolls on its own when
    taller than the page (a small screen), beside the results."""
    column = QWidget()
    column.setFixedWidth(LEFT_WIDTH)
    left = QVBoxLayout(column)
    left.setContentsMargins(0, 0, 0, 0)
    for k, panel in enumerate(panels):
        left.addWidget(panel, 1 if k == 0 else 0)
    scroll = QScrollArea()
    scroll.setObjectName("checkControlsScroll")
    scroll.setWidgetResizable(True)
    scroll.setFrameShape(QFrame.Shape.NoFrame)
    scroll.setHorizontalScrollBarPolicy(Qt.ScrollBarPolicy.ScrollBarAlwaysOff)
    scroll.setWidget(column)
    scroll.setFixedWidth(LEFT_WIDTH + scroll.style().pixelMetric(QStyle.PixelMetric.PM_ScrollBarExtent) + 2)
    return scroll


class CheckPage(WizardPage):
    step = Step.CHECK

    def __init__(self, state, tasks, **kwargs):
        super().__init__(state, tasks, **kwargs)
        self.controls, self.results = CheckControls(), CheckResults()
        self.teach, self.fixture = TeachCheckPanel(), FixturePanel()
        self.model = CheckModel(self.controls.options())
        for panel in (self.controls, self.results, self.fixture):
            panel.follow(self.model)
        self.inputs = CheckInputs(state, lambda: self.model.options)
        self.real_cell = RealCell(state, self.inputs, self.task, self._set_status, self)
        self.teach_poses = TeachPoses(state, self.model, self.teach, self.inputs, self.task,
                                      set_status=self._set_status, can_run=lambda: self.runs.can_run(),
                                      on_recorded=self.on_busy_changed)
        self.schedule = CheckSchedule(self, self.model, self.controls, self.inputs, self.task,
                                      run=lambda: self.run_check(), problem=self.real_cell.problem)
        self.schedule_timer = self.schedule.timer
        self.runs = CheckRuns(state, self.model, self.inputs, self.task, self.real_cell, self.teach_poses,
                              self.schedule, set_status=self._set_status, status_text=self.status.text,
                              finish_autopilot=self._finish_autopilot, refresh=self.refresh,
                              on_busy_changed=self.on_busy_changed)
        self.fixture_locator = FixtureLocator(self.model, self.fixture, self.inputs, self.task, self._set_status)

        self.controls.optionsChanged.connect(lambda: self.model.set_options(self.controls.options()))
        self.controls.run_button.clicked.connect(lambda *_: self.run_check())
        self.controls.choose_button.clicked.connect(lambda *_: self.choose_poses())
        self.controls.identify_tool_button.clicked.connect(lambda *_: self.identify_tool())
        self.results.reidentify_button.clicked.connect(lambda *_: self.reidentify())
        self.teach.record_button.clicked.connect(lambda *_: self.record_pose())
        self.teach.check_button.clicked.connect(lambda *_: self.run_check())
        self.fixture.locate_button.clicked.connect(lambda *_: self.locate_fixture())

        body = QHBoxLayout()
        body.addWidget(left_column(self.controls, self.teach, self.fixture), 0)
        body.addWidget(self.results, 1)
        layout = QVBoxLayout(self)
        layout.setContentsMargins(0, 0, 0, 0)
        layout.addLayout(body, 1)
        layout.addWidget(self.task.progress_row())
        layout.addWidget(self.status)

        for changed in (state.projectChanged, state.cellChanged, state.robotChanged):
            changed.connect(lambda *_: self.runs.calibration_changed())
        state.hardware.connectionChanged.connect(lambda *_: self.refresh())
        state.hardware.camerasChanged.connect(lambda *_: self.refresh())
        state.outputSaved.connect(lambda key: self.refresh() if key == "calibrated" else None)
        self.refresh()

    # -- what the tests and the autopilot read -------------------------------------------
    @property
    def cell(self):
        """The check poses and limits (app.jobs.check.CheckSetup; None: not chosen)."""
        return self.model.result.cell

    @property
    def result(self):
        """The last check (core.monitoring.check.CheckResult; None: none since the calibration)."""
        return self.model.result.check

    @property
    def diagnosis(self):
        return self.model.result.diagnosis

    @property
    def reidentification(self):
        """The last re-identification (app.jobs.check.Update)."""
        return self.model.result.update

    @property
    def tool_update(self):
        """The last identified tool (app.jobs.tool.ToolUpdate)."""
        return self.model.result.tool_update

    @property
    def fixture_run(self):
        """The last located fixture (app.jobs.fixture.FixtureRun)."""
        return self.model.result.fixture_run

    def calibrated_path(self) -> Path | None:
        return self.inputs.calibrated_path()

    def log_path(self) -> Path | None:
        return self.inputs.log_path()

    # -- page ----------------------------------------------------------------------------
    def on_enter(self) -> None:
        self.refresh()

    def is_complete(self) -> bool:
        return self.model.result.complete

    def refresh(self) -> None:
        """Read the check log and the calibration's presence, and draw them."""
        self.controls.show_cell(self.state.cell)
        if self.state.robot is not None:
            self.controls.set_dof(self.state.robot.dof)
            self.controls.set_tools(self.state.robot.tool_names())
        log, path = None, self.inputs.log_path()
        if path is not None and path.is_file():
            try:
                log = read_check_log(path)
            except RoboCalError as exc:
                self._set_status(f"✗ {exc.message}", False)
        self.model.take_log(log)
        busy = self.task.busy
        if not self.inputs.ready() and not busy:
            self._set_status(MISSING if self.state.project is not None else NO_PROJECT, False)
        elif not self.state.virtual and not busy and self.result is None:
            problem = self.real_cell.problem()
            self._set_status(f"This project measures on {self.state.cell}. "
                             + (f"Nothing can be measured: {problem}." if problem else "Ready to check."),
                             None if problem is None else False)
        elif not busy and self.status.text() in ("", MISSING, NO_PROJECT):     # words of before
            self._set_status(f"Ready to check the calibrated robot ({self.calibrated_path().name}) on the "
                             "virtual lab.", None)
        self.on_busy_changed()
        self.notify_complete()

    def on_busy_changed(self) -> None:
        busy, ready, teach = self.task.busy, self.inputs.ready(), self.inputs.teach_mode
        self.controls.set_enabled(busy, ready, self.state.virtual)
        self.results.reidentify_button.setEnabled(self.model.result.can_reidentify and not busy)
        self.fixture.set_enabled(busy, ready)
        self.fixture.set_virtual(self.state.virtual)
        self.teach.setVisible(teach)
        self.controls.allow_schedule(self.schedule.blocked(), busy)
        self.controls.identify_tool_button.setEnabled(self.controls.identify_tool_button.isEnabled() and not teach)
        if teach:
            self.teach_poses.show_next()

    def autopilot(self, done) -> None:
        """One check on the virtual lab, no change simulated."""
        self._autopilot_done = done
        self.controls.choose_change("", 1.5)
        self.run_check()

    # -- what the technician asks for ----------------------------------------------------
    def choose_poses(self) -> bool:
        """Choose the check poses now (they are chosen with the first check otherwise)."""
        return self.runs.choose_poses()

    def run_check(self) -> bool:
        """One check at every check pose (the poses are chosen first when needed)."""
        return self.runs.check()

    def reidentify(self) -> bool:
        """Re-identify what the diagnosis found and check the updated robot."""
        return self.runs.reidentify()

    def identify_tool(self) -> bool:
        """Identify the tool chosen as mounted and replace calibrated.json (the previous one kept)."""
        return self.runs.identify_tool()

    def record_pose(self) -> bool:
        """Teach mode: record the next check pose where the technician put the robot."""
        return self.teach_poses.record_pose()

    def locate_fixture(self) -> bool:
        """Locate the chosen fixture and write fixture_pose.json and fixture.urdf to the project."""
        return self.fixture_locator.locate()
