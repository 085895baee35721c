"""Measuring the marker on a connected cell: drive the robot to a pose, capture a stereo pair,
locate the marker (Qt-free; on the Check page's worker thread, or for `robocal check`,
`robocal identify-tool` with `--port`).

`CellMeasure(driver, cameras, locator, plan=Q)` is the `measure(q)` a check
(app.jobs.check → core.monitoring.check.run_check), a re-identification and a tool
identification call at each pose → the marker's centre (mm, left camera frame), or None when
it is not found:
- the driver refuses joint values outside the limits and sends nothing; the poses of a run given
  from the start are all checked before the first motion as well (the page: app.safety, the
  command line: app.jobs.check_sources.connected_cell);
- the pair is captured once the robot reports it arrived (and `settle_s` seconds later), from
  live cameras, video files or image folders (anything with `capture()`);
- with a `plan` (the poses in the order the run measures them, rad / mm; given, or `follow(plan)`
  once the run has chosen them), the move to the next planned pose starts as soon as a pair is
  captured, while the marker is located in it: the robot's motion and the image processing
  overlap. No move is started ahead once the run is cancelled, the robot stopped or a fault
  happened; a pose asked for out of the plan is driven to directly (and ends the moving ahead).

A robot or connection fault (the watchdog's timeout included) stops the robot, is kept in
`fault`, and the pose is not measured (RoboCalError); `cancelled()` is then true, so the run ends
after the points already measured, which stay in the check log. The Stop key ends it the same way
without a fault. The Check page shows what ended the run; the command line raises it once the run
ended (`raise_fault()`: exit 1). `finish()` (always, once the run is over) waits for a move made
ahead.

`cell_options(rig, ...)`: how a cell's poses are chosen: candidates that both calibrated cameras
see, facing them, inside the depth range the calibration measured.
"""
from __future__ import annotations

import threading
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np

from core.errors import RoboCalError
from core.marker.description import MarkerDescription
from core.marker.location import MarkerLocator
from core.measurement.file import read_measurements
from core.measurement.point import located_point
from core.poses.candidates import VisibilityOptions
from core.robot.driver import RobotDriver, RobotFault, RobotTimeout
from core.stereo.rectification import StereoRectification

DEPTH_MARGIN = 0.1          # the calibrated depth range widened by this fraction on each side


@dataclass
class CellMeasure:
    """`measure(q)` over a connected robot (`driver`) and the cell's two cameras (`cameras`, with
    `capture()` -> frames with `.left`, `.right`), the marker located by `locator`. `plan`: the
    poses the run measures, in order (rad / mm; None: no moving ahead). `settle_s`: seconds to
    wait after the robot reports it arrived, before capturing."""

    driver: RobotDriver
    cameras: object
    locator: MarkerLocator
    plan: np.ndarray | None = None
    settle_s: float = 0.0
    fault: str | None = None                 # the robot fault that ended the run, one line
    moves: int = 0                           # poses reached
    reached: list[np.ndarray] = field(default_factory=list)     # the joints the robot reported (rad / mm)
    _user: Callable[[], bool] | None = field(default=None, repr=False)
    _next: int = field(default=0, repr=False)          # index in plan of the pose measured next
    _ahead: threading.Thread | None = field(default=None, repr=False)
    _ahead_error: BaseException | None = field(default=None, repr=False)

    def __post_init__(self):
        if self.plan is not None:
            self.plan = np.atleast_2d(np.asarray(self.plan, dtype=float))

    def __call__(self, q) -> np.ndarray | None:
        if self.fault is not None:
            raise RoboCalError(f"not measured: {self.fault}")
        q = np.asarray(q, dtype=float)
        try:
            self._reach(q)
            self.reached.append(np.asarray(self.driver.current_joints(), dtype=float))
        except RobotFault as exc:
            if isinstance(exc, RobotTimeout) or not self.driver.stopped:   # not the Stop key
                self.fault = exc.message
                self.driver.stop()             # never raises; the robot stays stopped until Resume
            # a pose not measured (not a fault that ends the run at once: core.monitoring.check
            # re-raises those), so the run ends through `cancelled()` with the points measured kept
            raise RoboCalError(f"not measured: {exc.message}") from None
        self.moves += 1
        if self.settle_s > 0:
            time.sleep(self.settle_s)
        frames = self.cameras.capture()
        self._start_next()                     # the robot moves on while the marker is located in this pair
        return located_point(self.locator.locate(frames.left, frames.right))

    def follow(self, plan) -> None:
        """The poses the run measures from now on, in order (rad / mm), once they are known (a
        run that chooses them first): the robot moves on to the next while the marker is located."""
        self.finish()
        self.plan, self._next = np.atleast_2d(np.asarray(plan, dtype=float)), 0

    def cancelled(self, user: Callable[[], bool] | None = None) -> Callable[[], bool]:
        """The cancel check of a run: the user cancelled (`user`, also consulted before a move
        is started ahead), the robot faulted or was stopped."""
        self._user = user
        return lambda: self.ended

    @property
    def ended(self) -> bool:
        """The run must end: the user cancelled, the robot faulted or was stopped."""
        return bool((self._user is not None and self._user()) or self.fault is not None or self.driver.stopped)

    def raise_fault(self) -> None:
        """The fault that ended the run, as a RobotFault (the command line's exit 1); nothing
        when none did. The Stop key (the robot stopped without a fault) is one too."""
        if self.fault is not None:
            raise RobotFault(f"robot fault, the run stopped there (the points measured are kept): {self.fault}")
        if self.driver.stopped:
            raise RobotFault("the robot was stopped, the run stopped there (the points measured are kept)")

    def finish(self) -> None:
        """Wait for a move made ahead of a run that is over; its fault, if any, is kept in
        `fault` (and the robot stopped) though no pose is measured after it."""
        self._join()
        error, self._ahead_error = self._ahead_error, None
        if isinstance(error, RobotFault) and self.fault is None and (
                isinstance(error, RobotTimeout) or not self.driver.stopped):
            self.fault = error.message
            self.driver.stop()
        if self.plan is not None:
            self._next = len(self.plan)

    # -- moving ahead --------------------------------------------------------------------
    def _reach(self, q: np.ndarray) -> None:
        """Move to q: wait for the move made ahead when q is the next planned pose (its error
        raised here), else move there now."""
        ahead = self._ahead is not None
        self._join()
        if self._ahead_error is not None:
            error, self._ahead_error = self._ahead_error, None
            self._next = len(self.plan)
            raise error
        planned = self.plan is not None and self._next < len(self.plan) and np.array_equal(q, self.plan[self._next])
        if not (ahead and planned):
            self.driver.move_to(q)
        if self.plan is not None:
            self._next = self._next + 1 if planned else len(self.plan)

    def _start_next(self) -> None:
        if self.plan is None or self._next >= len(self.plan) or self.ended:
            return
        target = self.plan[self._next]

        def move():
            try:
                self.driver.move_to(target)
            except BaseException as exc:    # handed to the run by the next pose (or by finish)
                self._ahead_error = exc
        self._ahead = threading.Thread(target=move, name="robocal-move-ahead", daemon=True)
        self._ahead.start()

    def _join(self) -> None:
        if self._ahead is not None:
            self._ahead.join()
            self._ahead = None


def cell_options(rig, measurements: str | Path | None = None, *, plate_mm: float | None = None) -> dict:
    """Keyword arguments of the pose choosers (check poses, re-identification and tool poses) for a
    real cell: the calibrated stereo `rig` (core.stereo.calibration.StereoRig), the marker plate
    (`plate_mm` square, default: the shipped marker's), and the marker depths of the calibration's
    `measurements` file widened by 10 % (the choosers' default range when there is no file)."""
    plate = (plate_mm, plate_mm) if plate_mm else tuple(MarkerDescription.default().plate_size)
    options = {"rig": rig, "plate_size": plate}
    if measurements is not None and Path(measurements).is_file():
        z = np.asarray(read_measurements(measurements).xyz, dtype=float)[:, 2]
        if z.size:
            span = max(float(z.max() - z.min()), 1.0)
            options["visibility"] = VisibilityOptions(min_depth=max(1.0, float(z.min()) - DEPTH_MARGIN * span),
                                                      max_depth=float(z.max()) + DEPTH_MARGIN * span)
    return options


def locator(trained, stereo: StereoRectification) -> MarkerLocator:
    """The project's trained marker located through its stereo calibration."""
    if trained is None:
        raise RoboCalError("no trained marker", hint="Train the marker in step 3 (Marker).")
    if stereo is None:
        raise RoboCalError("no stereo calibration", hint="Calibrate the cameras in step 2 and save stereo.yaml.")
    return MarkerLocator(trained, stereo)
