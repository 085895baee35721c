"""The Check page on a real cell: what must hold before it measures (a robot connected and its
cameras open, or teach mode with the cameras), where it measures in words, the robot driven through
the check poses once app.safety allowed it, and what ended a run early (a robot fault or the Stop
key: the points measured stay in the log and the schedule is switched off).

A helper the page holds (`RealCell`), with its own state: the measure of the last run on the cell.
"""
from __future__ import annotations

from pathlib import Path
from typing import Callable

from app.hardware import is_real
from app.jobs.cell_measure import CellMeasure, locator
from app.pages.check.inputs import CheckInputs
from app.pages.page_task import BUSY
from app.pages.page_task import PageTask
from app.safety import motion_refused

CAMERAS_CLOSED = "the cell's cameras are not open: open them on the Setup page"
NO_MARKER = "the trained marker or the stereo calibration is missing: run the Stereo and Marker steps"


class RealCell:
    """The real-cell side of the Check page (`parent`: the widget the first-motion question is
    asked over; `set_status(text, ok)`: the page's status line)."""

    def __init__(self, state, inputs: CheckInputs, task: PageTask, set_status: Callable, parent):
        self.state = state
        self.inputs = inputs
        self.task = task
        self._set_status = set_status
        self._parent = parent
        self.measure: CellMeasure | None = None      # the measure of the last real-cell task

    def problem(self) -> str | None:
        """Why this real cell cannot be measured now (None: it can)."""
        hardware = self.state.hardware
        if not self.inputs.teach_mode:
            driver = hardware.robot_connection
            if not is_real(driver) or not driver.connected:
                return "no robot is connected: connect the cell's robot on the Setup page"
            lost = getattr(driver, "lost", None)
            if lost:
                return f"the connection to the robot is lost ({lost}): connect it again on the Setup page"
        if hardware.cameras is None:
            return CAMERAS_CLOSED
        if self.inputs.images() is None:
            return NO_MARKER
        return None

    def words(self) -> str:
        """Where a real-cell check measures: the robot's port and the cameras."""
        driver, cameras = self.state.hardware.robot_connection, self.state.hardware.cameras
        robot = ("the robot brought to each pose by hand (teach mode)" if self.inputs.teach_mode else
                 f"the serial robot on {getattr(driver, 'port', None) or driver.info.name}")
        choice = cameras.choice
        folders = choice is not None and all(Path(str(s)).is_dir() for s in (choice.left, choice.right))
        seen = (f"images from the folders {choice.left} and {choice.right}" if folders
                else f"the cameras {cameras.describe()}")
        return f"measured with {robot} and {seen}"

    def measure_for(self, Q=()) -> CellMeasure | None:
        """The `measure(q)` of a run on the cell, once the safety checks let the robot move (to the
        poses Q, when known; internal units: then the robot moves on to the next while the marker
        is located); None, with the reason on the page, when they do not (or while a run is busy:
        its measure stays the one whose fault the page reads)."""
        if self.task.busy:
            self._set_status(BUSY, False)
            return None
        refused = motion_refused(self._parent, self.state, Q)
        if refused:
            self._set_status(f"Nothing measured: {refused}", False)
            return None
        trained, rect = self.inputs.images()
        self.measure = CellMeasure(self.state.hardware.robot_connection, self.state.hardware.cameras,
                                   locator(trained, rect), plan=Q if len(Q) else None)
        return self.measure

    def fault_words(self, switch_off_schedule: Callable[[], bool]) -> str:
        """What ended the last real-cell run early (a robot fault or the Stop key), and what became of
        the schedule: it is switched off (`switch_off_schedule()`: whether it was on)."""
        measure = self.measure
        if measure is None or self.state.virtual:
            return ""
        if measure.fault is not None:
            why = f" Robot fault: {measure.fault}. The run stopped there"
        elif measure.driver.stopped:
            why = " The robot was stopped. The run ended there"
        else:
            return ""
        scheduled = switch_off_schedule()
        return (why + (" and the scheduled checks are off" if scheduled else "")
                + "; the points measured are kept in the log. Resume (Robot ▸ Resume after stop) when the way "
                  "is clear.")
