"""The Check page on a real cell: what must hold before it measures (a robot connected and its
cameras open, or teach mode with the cameras), where it measures in words, the robot driven through
the check poses once app.safety allowed it, and what ended a run early (a robot fault or the Stop
key: the points measured stay in the log and the schedule is switched off).

A mixin of CheckPage (before WizardPage): it uses the page's `state`, `cell`, `controls`,
`images()`, `_key()`, `_cell()`, `_take_cell`, `_checked` and `choose_poses`.
"""
from __future__ import annotations

from pathlib import Path

from app.hardware import is_real
from app.jobs import cell_check
from app.jobs.cell_measure import CellMeasure, cell_options, locator
from app.pages.measurement_inputs import stereo_source
from app.safety import motion_refused
from core.project import Output


class CellMixin:
    """The real-cell side of the Check page."""

    _measure: CellMeasure | None = None      # the measure of the last real-cell task

    def cell_problem(self) -> str | None:
        """Why this real cell cannot be measured now (None: it can)."""
        state = self.state
        if self.teach_mode:
            if state.hardware.cameras is None:
                return "the cell's cameras are not open: open them on the Setup page"
            if self.images() is None:
                return "the trained marker or the stereo calibration is missing: run the Stereo and Marker steps"
            return None
        driver = state.hardware.robot_connection
        if not is_real(driver) or not driver.connected:
            return "no robot is connected: connect the cell's robot on the Setup page"
        lost = getattr(driver, "lost", None)
        if lost:
            return f"the connection to the robot is lost ({lost}): connect it again on the Setup page"
        if state.hardware.cameras is None:
            return "the cell's cameras are not open: open them on the Setup page"
        if self.images() is None:
            return "the trained marker or the stereo calibration is missing: run the Stereo and Marker steps"
        return None

    @property
    def teach_mode(self) -> bool:
        """A real cell whose robot the technician brings to each pose (the project's choice)."""
        return self.state.project is not None and self.state.project.teach_mode

    def cell_words(self) -> str:
        """Where a real-cell check measures: the robot's port and the cameras."""
        driver, cameras = self.state.hardware.robot_connection, self.state.hardware.cameras
        robot = ("the robot brought to each pose by hand (teach mode)" if self.teach_mode else
                 f"the serial robot on {getattr(driver, 'port', None) or driver.info.name}")
        choice = cameras.choice
        folders = choice is not None and all(Path(str(s)).is_dir() for s in (choice.left, choice.right))
        seen = (f"images from the folders {choice.left} and {choice.right}" if folders
                else f"the cameras {cameras.describe()}")
        return f"measured with {robot} and {seen}"

    def _cell_options(self) -> dict:
        """How the real cell's poses are chosen: its calibrated cameras and measured depths."""
        return cell_options(stereo_source(self.state).rect.calibration.rig, self.state.project.path(Output.MEASUREMENTS))

    def _cell_measure(self, Q=()) -> CellMeasure | None:
        """The `measure(q)` of a run on the cell, once the safety checks let the robot move (to the
        poses Q, when known; internal units: then the robot moves on to the next while the marker
        is located); None, with the reason on the page, when they do not (or while a run is busy:
        its measure stays the one whose fault the page reads)."""
        if self.task.busy:
            self._set_status("Busy: wait for the running task or cancel it.", False)
            return None
        refused = motion_refused(self, self.state, Q)
        if refused:
            self._set_status(f"Nothing measured: {refused}", False)
            return None
        self._where = self.cell_words()
        trained, rect = self.images()
        self._measure = CellMeasure(self.state.hardware.robot_connection, self.state.hardware.cameras, locator(trained, rect),
                                    plan=Q if len(Q) else None)
        return self._measure

    def _check_cell(self) -> bool:
        """A check on the real cell: the check poses first when needed (on a worker), then the
        robot is driven through them once app.safety allowed it (teach mode: the poses recorded by
        hand are checked once every one is recorded)."""
        key = self._key()
        cell = self._cell()
        if self.teach_mode:
            if cell is None:
                return self.choose_poses()
            return self._check_taught()
        if cell is None:
            return self.task.start(cell_check.setup_cell, self.calibrated_path(), self._cell_options(), count=key[2],
                              tool=key[3], on_done=lambda c: (self._take_cell(c, key), self._drive_check(key)),
                              status="Choosing check poses for the cell's cameras…")
        return self._drive_check(key)

    def _drive_check(self, key: tuple) -> bool:
        measure = self._cell_measure(self.cell.Q)
        if measure is None:
            self._finish_autopilot(False, self.status.text())
            return False
        return self.task.start(cell_check.check_cell, self.cell, measure, log=self.log_path(),
                          on_done=lambda value: self._checked((self.cell, *value), key),
                          status=f"Checking: {self._where}… Esc stops the robot.")

    def _fault_words(self) -> str:
        """What ended the last real-cell run early (a robot fault or the Stop key), and what became of
        the schedule: it is switched off."""
        measure = self._measure
        if measure is None or self.state.virtual:
            return ""
        if measure.fault is not None:
            why = f" Robot fault: {measure.fault}. The run stopped there"
        elif measure.driver.stopped:
            why = " The robot was stopped. The run ended there"
        else:
            return ""
        scheduled = self.controls.schedule_check.isChecked()
        self.controls.schedule_check.setChecked(False)
        return (why + (" and the scheduled checks are off" if scheduled else "")
                + "; the points measured are kept in the log. Resume (Robot ▸ Resume after stop) when the way "
                  "is clear.")
