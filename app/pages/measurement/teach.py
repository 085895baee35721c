"""Teach mode of the Measurement page, for a robot RoboCal does not move (none connected, or a
controller that only reports its joints), or when the technician chooses it: the page shows
the next pose, the technician brings the robot there with its pendant, and Record pose reads
the joints from the controller (or takes the values typed or pasted from the pendant), checks
them against the joint limits and the plan, captures, locates and writes the pose
(app.jobs.measurement_hardware.record_taught_pose, on a worker).

`Teaching` is held by the page (composed, not a base class): it is given the page's model, task,
run controls, teach panel, views, splitter and table, and the page's callables (`TeachHooks`);
the technician's choice of teach mode is the model's option `teach_chosen`.
"""
from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path
from typing import Callable

from PySide6.QtWidgets import QSplitter

from app.jobs.measurement import MEASURED, PENDING, PoseRow
from app.jobs.measurement_hardware import capture_source, off_plan, record_taught_pose, typed_joints
from app.pages.measurement.controls import RunControls
from app.pages.measurement.model import MeasurementModel
from app.pages.measurement.pose_table import PoseTable
from app.pages.measurement.teach_panel import TeachPanel, pose_html
from app.pages.measurement.views import MeasurementViews
from app.pages.measurement_inputs import run_inputs
from app.pages.page_task import PageTask
from core.errors import RoboCalError
from core.poses.candidates import arm_polyline


@dataclass
class TeachHooks:
    """What teach mode needs of its page, as plain callables on the GUI thread."""

    say: Callable[[str, bool | None], None]          # the page's status line
    measurements_path: Callable[[], Path | None]
    update_buttons: Callable[[], None]               # the run's buttons (they show the next pose too)
    ready_status: Callable[[], None]                 # the status line before a run
    is_complete: Callable[[], bool]


class Teaching:
    """Teach mode: forced when RoboCal cannot move the robot, else the technician's choice."""

    def __init__(self, model: MeasurementModel, task: PageTask, state, *, controls: RunControls,
                 panel: TeachPanel, views: MeasurementViews, splitter: QSplitter, table: PoseTable,
                 hooks: TeachHooks):
        self.model, self.task, self.state, self.hooks = model, task, state, hooks
        self.controls, self.panel, self.views, self.splitter, self.table = controls, panel, views, splitter, table

    # -- mode ------------------------------------------------------------------------------
    def drivable(self) -> bool:
        """RoboCal can move the connected robot."""
        driver = self.state.hardware.robot_connection
        return driver is not None and driver.connected and driver.info.can_move

    def _readable(self):
        """The connected driver when its joints can be read now, else None."""
        driver = self.state.hardware.robot_connection
        if driver is None or not driver.connected or getattr(driver, "lost", None):
            return None
        return driver

    @property
    def teach_mode(self) -> bool:
        forced = not self.state.virtual and not self.drivable()
        return forced or self.model.options.teach_chosen

    def connection_changed(self, *_) -> None:
        """Another robot connection: its joints are read when they can be."""
        self.panel.show_options(replace(self.panel.options(), read_from_controller=self._readable() is not None))
        self.update_mode()

    def toggled(self, _on: bool) -> None:
        """Teach mode ticked or unticked (a forced teach mode stays)."""
        if self.controls.teach_check.isEnabled():
            self.model.set_options(replace(self.model.options, teach_chosen=self.controls.options().teach))
        self.update_mode()

    def update_mode(self) -> None:
        """Teach panel or run views, the Teach mode box, the buttons (`update_buttons` also
        shows the next pose)."""
        forced = not self.state.virtual and not self.drivable()
        teach = self.teach_mode
        self.controls.show_options(replace(self.controls.options(), teach=teach))
        self.controls.teach_check.setToolTip(
            "RoboCal cannot move this robot: bring it to each pose with its pendant" if forced else
            "Bring the robot to each pose yourself (pendant or by hand); RoboCal only captures")
        if teach != self.panel.isVisible():
            self.panel.setVisible(teach)
            self.views.setVisible(not teach)
            total = sum(self.splitter.sizes()) or 560
            self.splitter.setSizes([total * 9 // 20, 0, total * 11 // 20] if teach else [total // 2, total // 2, 0])
        self.hooks.update_buttons()
        if not self.task.busy and self.model.poses is not None:
            self.hooks.ready_status()

    # -- the next pose ---------------------------------------------------------------------
    def _row(self) -> PoseRow | None:
        """The selected pose when it is not measured yet, else the first pose still to measure."""
        rows, i = self.model.rows, self.table.selected()
        if i is not None and 0 <= i < len(rows) and rows[i].status != MEASURED:
            return rows[i]
        return next((r for r in rows if r.status == PENDING), None)

    def show(self) -> None:
        """The next pose in the teach panel (nothing outside teach mode)."""
        if not self.teach_mode:
            return
        row, robot, rows, poses = self._row(), self.state.robot, self.model.rows, self.model.poses
        if row is None or robot is None or poses is None:
            self.panel.show_pose("<b>No pose left to record.</b>" if rows else "<b>No pose list.</b>", None)
        else:
            left = sum(1 for r in rows if r.status != MEASURED)
            arm = arm_polyline(robot, poses.Q[row.index:row.index + 1])[0][0]
            self.panel.show_pose(pose_html(row.pose, f"{left} of {len(rows)} still to measure", robot,
                                           poses.q_file[row.index]), arm)
        self.typed_changed(self.panel.options().typed)
        self.panel.set_enabled(busy=self.task.busy, can_read=self._readable() is not None, has_pose=row is not None)

    def typed_changed(self, text: str) -> None:
        """Check the typed values against the limits and the plan as they are typed."""
        row, robot = self._row(), self.state.robot
        if self.panel.options().read_from_controller or row is None or robot is None or not text.strip():
            self.panel.show_check([])
            return
        try:
            q_file = typed_joints(text, robot)
        except RoboCalError as exc:
            self.panel.show_check([("bad", f"{exc.problem}. {exc.hint or ''}".strip())])
            return
        far = off_plan(robot, q_file, self.model.poses.q_file[row.index])
        self.panel.show_check([("ok", "Inside the joint limits.")] +
                              [("warn", f"{w}: check the pendant.") for w in far])

    def use_plan(self) -> None:
        """The planned values of the pose shown into the field (to correct to what the pendant shows)."""
        row = self._row()
        if row is not None:
            typed = " ".join(f"{v:g}" for v in self.model.poses.q_file[row.index])
            self.panel.show_options(replace(self.panel.options(), typed=typed))

    # -- recording -------------------------------------------------------------------------
    def record(self) -> bool:
        """Record the pose shown where the robot is now (a worker task); False when refused."""
        if self.task.busy:
            return False
        say, state = self.hooks.say, self.state
        try:
            trained, src = run_inputs(state, self.model.poses)
        except RoboCalError as exc:
            say(f"Cannot record: {exc.message}. {exc.hint or ''}".strip(), False)
            return False
        row, robot, source_of_joints = self._row(), state.robot, self.panel.options()
        if row is None:
            say("Every pose is measured.", None)
            return False
        driver = self._readable() if source_of_joints.read_from_controller else None
        typed = None
        if driver is None:
            try:
                typed = typed_joints(source_of_joints.typed, robot)
            except RoboCalError as exc:
                say(f"✗ Pose {row.pose} not recorded: {exc.problem}. {exc.hint or ''}".strip(), False)
                return False
            if state.hardware.cameras is None and state.virtual:
                say("The virtual lab's cameras see the simulated robot: read its joints from the "
                    "controller (jog it on the Setup page), or open cameras.", False)
                return False
        planned, path = self.model.poses.q_file[row.index], self.hooks.measurements_path()

        def go(lab):
            try:
                source = capture_source(state.hardware.cameras, lab=lab, driver=driver, seed=int(state.seed))
            except RoboCalError as exc:
                say(f"Cannot record: {exc.message}", False)
                return False
            return self.task.start(record_taught_pose, row.pose, planned, path, trained, src.rect, source, robot,
                                   driver=driver, q_typed_file=typed, on_done=self._taught,
                                   on_failed=self._failed, label="Recording", status=f"Recording pose {row.pose}…")

        return self.task.with_lab(go) if state.hardware.cameras is None and state.virtual else go(None)

    def _taught(self, taught) -> None:
        outcome = taught.outcome
        self.model.record(outcome, taught.thumbnail)
        if self.hooks.is_complete():
            self.state.set_measurements(self.hooks.measurements_path())
        self.panel.show_options(replace(self.panel.options(), typed=""))
        nxt = self._row()
        then = f" Next: pose {nxt.pose}." if nxt is not None else " Every pose is done."
        off = f" ({'; '.join(taught.warnings)})" if taught.warnings else ""
        if outcome.status == MEASURED:
            self.hooks.say(f"✓ Pose {outcome.pose} recorded{off}.{then}", None if nxt is not None else True)
        else:
            self.hooks.say(f"✗ Pose {outcome.pose} rejected: {outcome.reason}. Bring the robot there again and "
                           f"record it, or select another pose.", False)
        self.show()
        self.panel.show_check([("warn", w) for w in taught.warnings])

    def _failed(self, message: str) -> None:
        self.hooks.say(f"✗ Not recorded: {message}", False)
        self.show()
