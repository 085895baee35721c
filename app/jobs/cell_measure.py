"""Measuring the marker on a real cell, for the Check step (Qt-free; called on a worker thread).

`CellMeasure(driver, cameras, locator)` is the `measure(q)` that app.jobs.check's `check`,
`reidentify_from_proposed` and the tool identification call at each pose: it drives the connected
robot to q (the driver refuses joint values outside the limits and sends nothing), captures a pair
from the project's cameras once the robot has settled (live cameras, video files or image
folders: app.hardware.LiveCameras), and locates the project's trained marker in it → the marker's
centre (mm, left camera frame) or None when it is not found.

A robot or connection fault ends the run: the robot is stopped, the fault is kept in `fault`,
and `cancelled()` becomes true, so the check ends after the points already measured (they stay
in the check log) instead of driving on. The Stop key (the robot stopped) ends it the same way,
without a fault.

`cell_options(stereo, measurements)`: how the cell's check poses are chosen: candidates that both
calibrated cameras see, facing them, inside the depth range the calibration measured.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np

from core.errors import RoboCalError
from core.marker.description import MarkerDescription
from core.marker.location import MarkerLocator
from core.measurement.file import read_measurements
from core.poses.candidates import VisibilityOptions
from core.robot.driver import RobotDriver, RobotFault
from core.stereo.rectification import StereoRectification

DEPTH_MARGIN = 0.1          # the calibrated depth range widened by this fraction on each side


@dataclass
class CellMeasure:
    """`measure(q)` over a connected robot (`driver`) and the project's two cameras (`cameras`,
    an app.hardware.LiveCameras or anything with `capture()`), the marker located by `locator`.
    `settle_s`: seconds to wait after the robot reports it arrived, before capturing."""

    driver: RobotDriver
    cameras: object
    locator: MarkerLocator
    settle_s: float = 0.0
    fault: str | None = None                 # the robot fault that ended the run, one line
    moves: int = 0                           # poses driven to
    reached: list[np.ndarray] = field(default_factory=list)     # the joints the robot reported (rad / mm)

    def __call__(self, q) -> np.ndarray | None:
        if self.fault is not None:
            raise RoboCalError(f"not measured: {self.fault}")
        try:
            self.driver.move_to(q)
            self.reached.append(np.asarray(self.driver.current_joints(), dtype=float))
        except RobotFault as exc:
            if not self.driver.stopped:        # a fault, not the Stop key (which already stopped it)
                self.fault = exc.message
                self.driver.stop()             # never raises; the robot stays stopped until Resume
            # a pose not measured (not a fault that ends the run at once: core.monitoring.check
            # re-raises those), so the run ends through `cancelled()` with the points measured kept
            raise RoboCalError(f"not measured: {exc.message}") from None
        self.moves += 1
        if self.settle_s > 0:
            time.sleep(self.settle_s)
        frames = self.cameras.capture()
        location = self.locator.locate(frames.left, frames.right)
        return location.point if location.ok else None

    def cancelled(self, user: Callable[[], bool] | None = None) -> Callable[[], bool]:
        """The cancel check of a run: the user cancelled, the robot faulted or was stopped."""
        return lambda: bool((user is not None and user()) or self.fault is not None or self.driver.stopped)


def cell_options(stereo: StereoRectification, measurements: str | Path | None = None) -> dict:
    """Keyword arguments of the pose choosers (check poses, re-identification and tool poses) for a
    real cell: the calibrated stereo rig, the shipped marker's plate, and the marker depths of the
    calibration's measurements (`measurements`, widened by 10 %; the choosers' default range when
    there is no file)."""
    options = {"rig": stereo.calibration.rig,
               "plate_size": tuple(MarkerDescription.default().plate_size)}
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
