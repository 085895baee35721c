"""The Measurement step over the chosen hardware (worker-thread functions the Measurement page
calls; plain Python, no widgets are touched).

`measure_hardware(...)`: core.measurement.run.run_measurements over the robot connection
(any RobotDriver: the virtual lab's simulated robot or a SerialRobot) and a capture source
(`capture_source(...)`: the two chosen cameras, app.hardware.LiveCameras, or the virtual
lab's cameras rendering the marker at the joints the robot reports). Pause, cancel and the
robot's Stop end it between poses; a robot or connection fault (a move the driver's watchdog
stopped included: RobotTimeout, never taken for the Stop key) stops the robot, keeps every
measurement and comes back in `result.fault`; running it again resumes at the first pose not
measured.

Teach mode, for a robot RoboCal does not drive: the technician brings the robot to the next
pose with its own pendant (or by hand); `record_taught_pose(...)` reads the joints from the
controller (or takes the values the technician typed), checks them against the joint limits
and the planned pose (a warning above `tolerance` deg / mm), captures, locates, and writes
the pose to the same measurements file (or the rejects file, with the reason).

Joint values: internal units (rad / mm) unless named `_file` (deg / mm). Points: mm, left
camera frame.
"""
from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np

from core.errors import RoboCalError
from core.measurement.capture import RenderedSource
from core.measurement.file import read_measurements
from core.measurement.run import MeasurementRunResult, PoseOutcome, poses_from_internal, run_measurements
from core.poses.file import PoseList
from core.robot.driver import RobotDriver, check_joint_values
from core.robot.model import RobotModel
from core.thumbnails import marker_pair_thumbnail

THUMB_WIDTH = 400            # px per camera in the thumbnail handed to `report`
TEACH_TOLERANCE = 1.0        # deg / mm: a taught pose further than this from the plan is warned about


def capture_source(cameras=None, *, lab=None, driver: RobotDriver | None = None, seed: int = 0):
    """What the run captures from: the chosen cameras when there are any (LiveCameras), else the
    virtual lab's cameras rendering the marker where the robot is now (its reported joints)."""
    if cameras is not None:
        return cameras
    if lab is None or driver is None:
        raise RoboCalError("no cameras to capture from", hint="Open the cameras on the Setup page.")
    rng = np.random.default_rng([int(seed), 41])
    return RenderedSource(lambda: lab.render_marker_pair(driver.current_joints(), rng))


class _Recorder:
    """Keeps the last pair and location so `report(outcome, thumbnail)` can draw them."""

    def __init__(self, source, locator, report: Callable | None):
        self.source, self.locator, self.report = source, locator, report
        self.pair = self.location = None

    def capture(self):
        frames = self.source.capture()
        self.pair, self.location = (frames.left, frames.right), None
        return frames

    def locate(self, left, right):
        self.location = self.locator.locate(left, right)
        return self.location

    def on_pose(self, outcome: PoseOutcome) -> None:
        if self.report is not None:
            self.report(outcome, self.thumbnail(outcome.status == "measured"))
        self.pair = self.location = None

    def thumbnail(self, ok: bool):
        if self.pair is None:
            return None
        loc = self.location
        dl, dr = (loc.left, loc.right) if loc is not None else (None, None)
        good = [d if d is not None and d.ok else None for d in (dl, dr)]
        return marker_pair_thumbnail(self.pair[0], self.pair[1],
                                     good[0].outline.corners if good[0] else None,
                                     good[1].outline.corners if good[1] else None,
                                     good[0].reference if good[0] else None,
                                     good[1].reference if good[1] else None, ok=ok, width=THUMB_WIDTH)


def _locator(trained, rect):
    from core.marker.location import MarkerLocator

    return MarkerLocator(trained, rect)


def measure_hardware(poses: PoseList, out: str | Path, trained, rect, driver: RobotDriver, source, *,
                     paused=None, report: Callable | None = None, progress=None,
                     cancelled=None) -> MeasurementRunResult:
    """Move `driver` through `poses`, capture from `source` once the robot settled, locate the
    marker (`trained`, stereo rectification `rect`), write each pose at once to `out` (and its
    rejects file). `report(outcome, thumbnail)` after each pose (worker thread). Resumes after
    the poses already in the files. A robot stopped meanwhile ends the run before the next pose
    (like a cancel); a fault comes back in `result.fault`."""
    rec = _Recorder(source, _locator(trained, rect), report)

    def stop_requested() -> bool:
        return bool((cancelled is not None and cancelled()) or driver.stopped)

    return run_measurements(poses, out, locate=rec.locate, source=rec, driver=driver, resume=True,
                            keep_locations=False, on_pose=rec.on_pose, progress=progress,
                            cancelled=stop_requested, paused=paused)


@dataclass
class TaughtPose:
    """A pose recorded in teach mode."""

    outcome: PoseOutcome
    q_file: np.ndarray                  # the joint values recorded (deg / mm)
    warnings: list[str] = field(default_factory=list)
    thumbnail: np.ndarray | None = None


def record_taught_pose(pose: int, q_planned_file, out: str | Path, trained, rect, source, model: RobotModel, *,
                       driver: RobotDriver | None = None, q_typed_file=None, tolerance: float = TEACH_TOLERANCE,
                       target: str = "marker", progress=None, cancelled=None) -> TaughtPose:
    """Record pose `pose` where the technician put the robot: its joints read from `driver`
    (or `q_typed_file`, deg / mm, when no driver can read them), checked against the joint
    limits (RoboCalError naming the joint) and against the plan (a warning per joint further
    than `tolerance`), then captured from `source`, located and written to `out`."""
    q = taught_joints(model, driver, q_typed_file)
    out = Path(out)
    if out.is_file() and out.read_bytes().strip() and pose in {int(p) for p in read_measurements(out).pose}:
        raise RoboCalError(f"pose {pose} is already measured", source=out, hint="Go on with the next pose.")
    q_file = np.asarray(model.q_to_file(q), dtype=float)
    warnings = off_plan(model, q_file, q_planned_file, tolerance)
    rec = _Recorder(source, _locator(trained, rect), None)
    result = run_measurements(poses_from_internal(q[None, :], model, ids=[pose]), out, locate=rec.locate,
                              source=rec, target=target, resume=True, retry_rejected=True, keep_locations=False,
                              progress=progress, cancelled=cancelled)
    outcome = result.outcomes[0] if result.outcomes else PoseOutcome(0, pose, q_file, "skipped", "cancelled")
    return TaughtPose(outcome, q_file, warnings, rec.thumbnail(outcome.status == "measured"))


def taught_joints(model: RobotModel, driver: RobotDriver | None, q_typed_file=None) -> np.ndarray:
    """Where the technician put the robot (internal units): the joints read from `driver`, or
    else typed (`q_typed_file`, deg / mm); inside the joint limits (RoboCalError naming the joint)."""
    if driver is not None:
        q = driver.current_joints()
    elif q_typed_file is not None:
        q = model.q_from_file(np.asarray(q_typed_file, dtype=float).reshape(-1))
    else:
        raise RoboCalError("no joint values: connect a robot whose joints can be read, or type them",
                           field="joints")
    return inside_limits(model, q)


def inside_limits(model: RobotModel, q) -> np.ndarray:
    """`q` (rad / mm) when every joint is inside its limits, else a RoboCalError naming the
    joint, its value and its limits (deg / mm)."""
    try:
        return check_joint_values(model, q, "the joint values")
    except RoboCalError as exc:
        raise RoboCalError(exc.problem.replace("; the robot was not moved", ""), source=exc.source,
                           hint="Move the robot inside its joint limits, or correct the typed values.") from None


def off_plan(model: RobotModel, q_file, q_planned_file, tolerance: float = TEACH_TOLERANCE) -> list[str]:
    """One warning per joint further than `tolerance` (deg / mm) from the planned pose."""
    q_file = np.asarray(q_file, dtype=float).reshape(-1)
    planned = np.asarray(q_planned_file, dtype=float).reshape(-1)
    warnings = []
    for i, joint in enumerate(model.joints):
        off = abs(q_file[i] - planned[i])
        if off > tolerance:
            unit = "°" if joint.revolute else " mm"
            warnings.append(f"{joint.name or f'J{i + 1}'} is {off:.2f}{unit} from the planned pose")
    return warnings


def typed_joints(text: str, model: RobotModel) -> np.ndarray:
    """Joint values typed or pasted by the technician (deg / mm; separated by spaces, commas,
    semicolons or tabs; a comma is a decimal mark when semicolons, or tabs without spaces,
    separate them, as a spreadsheet pastes them), checked against the joint limits.
    RoboCalError saying what is wrong."""
    text = text.strip()
    if not text:
        raise RoboCalError("no joint values typed", field="joints",
                           hint=f"Type the {model.dof} values the robot's pendant shows.")
    if ";" in text or ("\t" in text and " " not in text):
        parts = [p.strip().replace(",", ".") for p in re.split(r"[;\t\n]+", text) if p.strip()]
    else:
        parts = [p for p in re.split(r"[,\s]+", text) if p]
    try:
        values = np.array([float(p) for p in parts])
    except ValueError:
        bad = next(p for p in parts if not _is_number(p))
        raise RoboCalError(f"'{bad}' is not a number", field="joints",
                           hint="Type numbers only: degrees, or mm for sliding joints.") from None
    if values.size != model.dof:
        raise RoboCalError(f"{values.size} joint values typed, the robot has {model.dof}", field="joints",
                           hint="Type one value per joint, J1 first.")
    return np.asarray(model.q_to_file(inside_limits(model, model.q_from_file(values))), dtype=float)


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True
