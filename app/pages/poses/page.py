"""Step 4, Pose sequence: robot configurations that make the geometric parameters observable.

The page runs app.jobs.poses.run_pose_selection on a worker thread (progress, Cancel) and
draws what it returns (results.py). In the virtual lab the candidates are limited to poses
where both cameras see the marker, above the table: the page asks the state for the lab
(`state.labs.when_ready`, built once on a worker) before it starts the selection. The selection (or the
project's poses.csv) is the model's (model.py), the results drawn from it. The result goes to
the Measurement step as ``state.poses`` (a PoseSelectionResult: ``.Q`` rad/mm, ``.q_file``
deg/mm, ``.path``) and as the project's poses.csv.
"""
from __future__ import annotations

from PySide6.QtWidgets import QVBoxLayout

from app.jobs.poses import run_pose_selection
from app.pages.base import WizardPage
from app.pages.poses.controls import SelectionControls
from app.pages.poses.model import PosesModel
from app.pages.poses.results import SelectionResults
from app.pages.poses.texts import SHORT
from app.pages.steps import Step
from core.errors import RoboCalError
from core.locks import output_lock
from core.poses.selection import PoseSelectionResult, write_selection
from core.project import Output
from widgets.wrapping_box import hold_height_for_width


class PosesPage(WizardPage):
    step = Step.POSES

    def __init__(self, state, tasks, **kwargs):
        super().__init__(state, tasks, **kwargs)
        self.model = PosesModel()

        self.controls = hold_height_for_width(SelectionControls())     # its rows wrap on a small screen
        self.results = SelectionResults()
        # the widgets tests and the autopilot reach by name
        self.count_spin, self.candidates_spin = self.controls.count_spin, self.controls.candidates_spin
        self.select_button = self.controls.select_button
        self.cancel_button = self.task.progress_row().cancel_button
        self.curve_plot, self.summary, self.facts = (self.results.curve_plot, self.results.summary,
                                                     self.results.facts)
        self.views, self.table = self.results.views, self.results.table

        layout = QVBoxLayout(self)
        layout.setContentsMargins(0, 0, 0, 0)
        layout.setSpacing(6)
        layout.addWidget(self.controls)
        layout.addWidget(self.task.progress_row())
        layout.addWidget(self.results, 1)
        layout.addWidget(self.status)

        self.controls.selectRequested.connect(lambda: self.start_selection())
        self.controls.indexChanged.connect(lambda: self.results.set_index(self.index()))
        state.projectChanged.connect(self._context_changed)
        state.robotChanged.connect(self._context_changed)
        state.labChanged.connect(lambda *_: self._draw())
        self.model.on("result", lambda _result: self._show())
        self._show()

    # -- state -----------------------------------------------------------------------------
    @property
    def result(self) -> PoseSelectionResult | None:
        """This session's selection (None: none, or only the project's poses.csv)."""
        return self.model.result

    def index(self) -> str:
        return self.controls.index()

    def set_index(self, key: str) -> None:
        self.controls.set_index(key)

    def _context_changed(self, *_):
        """Another project or robot: the selection no longer applies."""
        self.task.forget()
        self.model.selected(None)
        self._load_existing()
        self._show()
        self.notify_complete()

    def _load_existing(self) -> None:
        """A poses.csv already in the project (an earlier session) counts as the selection."""
        try:
            self.model.load_existing(self.state.project, self.state.robot)
        except RoboCalError as exc:
            self._set_status(f"The project's poses.csv cannot be used ({exc.message}); select the poses again.",
                             ok=False)

    # -- WizardPage ------------------------------------------------------------------------
    def on_enter(self) -> None:
        if not self.model.complete:
            self._load_existing()
            self._show()
        self.notify_complete()

    def is_complete(self) -> bool:
        return self.model.complete

    def autopilot(self, done) -> None:
        if self.state.project is None or self.state.robot is None:
            done(False, "no project or robot model (Setup step)")
            return
        self.controls.set_demo()
        self._autopilot_done = done
        if not self.start_selection():
            self._finish_autopilot(False, self.status.text() or "pose selection could not start")

    def on_busy_changed(self) -> None:
        self.controls.set_busy(self.task.busy)

    def on_cancelled(self) -> None:
        kept = " The previous selection is kept." if self.is_complete() else ""
        self._set_status("Cancelled." + kept, ok=False)
        self._finish_autopilot(False, "cancelled")

    # -- the work ----------------------------------------------------------------------------
    def start_selection(self) -> bool:
        """Select poses with the controls' settings: in the virtual lab (asked for first) or, for
        a hardware project, among every feasible pose of the robot."""
        if self.task.busy:
            return False
        robot = self.state.robot
        if robot is None:
            self._set_status("Choose a robot model in the Setup step first.", ok=False)
            return False
        self.model.set_options(self.controls.options())
        options = self.model.options
        status = f"Selecting {options.count} poses by {SHORT[options.index]}…"
        start = self.task.start_with_lab if self.state.virtual else self.task.start
        return start(run_pose_selection, robot, options.count, on_done=self._selected, status=status,
                     label="Selecting poses", **options.keywords())

    def _selected(self, r: PoseSelectionResult) -> None:
        written = ""
        if self.state.project is not None:
            try:
                with output_lock(self.state.project.path(Output.POSES)):     # not while a robocal command writes it
                    path = write_selection(r, self.state.project.path(Output.POSES))
                written = f" Written to {path.name} for the Measurement step."
            except RoboCalError as exc:
                self.show_error(exc.message)
                written = " (poses.csv could not be written)"
        self.state.set_poses(r)
        self.model.selected(r)
        self._set_status(f"✓ {r.count} poses selected in {r.seconds:.1f} s.{written}", ok=True)
        self.notify_complete()
        if self._autopilot_done is not None:
            self._finish_autopilot(True, f"{r.count} poses, {SHORT[r.index]} {r.value():.3g} "
                                         f"(random median {r.random_median():.3g})")

    # -- drawing ---------------------------------------------------------------------------
    def _draw(self) -> None:
        self.results.set_selection(self.model.result, self.model.loaded, lab=self.state.labs.current,
                                   robot=self.state.robot, index=self.index())

    def _show(self) -> None:
        self._draw()
        result, loaded = self.model.result, self.model.loaded
        if result is None and loaded is None and not self.task.busy:
            if self.state.robot is None:
                self._set_status("Choose a robot model in the Setup step first.", ok=False)
            else:
                where = "the virtual lab's cameras" if self.state.virtual else "the robot (no camera constraint)"
                self._set_status(f"Choose N and the index, then Select poses (candidates for {where}).", ok=None)
        elif loaded is not None and result is None:
            self._set_status(f"✓ {len(loaded)} poses from the project's poses.csv. Select again to see "
                             "their observability.", ok=True)

    def highlight(self, row: int) -> None:
        """Select table row `row` (its arm is drawn in the views)."""
        self.results.highlight(row)
