"""The Check step in teach mode (Qt-free; the Check page runs these on a worker), for a real cell
whose robot RoboCal does not drive: the technician brings the robot to each check pose with its
pendant and records it; the joints are typed (deg / mm) or read from the controller, the pair is
captured from the project's cameras and the marker located. Once every pose is recorded, the check
is judged and logged as any other, at the joints recorded (its limits computed for them).

Joint values: internal units (rad / mm) unless named `_file` (deg / mm). Points: mm, left camera
frame."""
from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from app.jobs import check as job
from app.jobs.measurement_hardware import off_plan, taught_joints
from core.errors import RoboCalError
from core.measurement.point import located_point
from core.monitoring.check import check_limits
from core.robot.driver import RobotDriver


@dataclass
class TaughtCheckPose:
    """One check pose recorded by hand: the joints recorded, the marker found (None: not found)."""

    index: int
    q: np.ndarray
    point: np.ndarray | None           # a MeasuredPoint (its covariance), None: not found
    warnings: list[str] = field(default_factory=list)     # joints further than 1° / 1 mm from the plan


def record_check_pose(cell: job.CheckSetup, index: int, cameras, locator, *, q_typed_file=None,
                      driver: RobotDriver | None = None, progress=None, cancelled=None) -> TaughtCheckPose:
    """Record check pose `index` where the technician put the robot: its joints read from `driver`
    (or `q_typed_file`, deg / mm), checked against the joint limits (RoboCalError naming the joint)
    and the planned pose (warnings), then a pair captured from `cameras` and the marker located."""
    model = cell.model
    q = taught_joints(model, driver, q_typed_file)
    warnings = off_plan(model, model.q_to_file(q), model.q_to_file(cell.Q[index]))
    frames = cameras.capture()
    location = locator.locate(frames.left, frames.right)
    return TaughtCheckPose(index, q, located_point(location), warnings)


def check_taught(cell: job.CheckSetup, taught: list[TaughtCheckPose], *, log=None, progress=None, cancelled=None):
    """The check of the poses recorded by hand (in pose order, at the joints recorded), appended to
    `log`, and its diagnosis when it left its limits."""
    if sorted(t.index for t in taught) != list(range(len(cell.Q))):
        raise RoboCalError(f"{len(taught)} of the {len(cell.Q)} check poses recorded",
                           hint="Record every check pose, one by one, then check.")
    taught = sorted(taught, key=lambda t: t.index)
    Q = np.array([t.q for t in taught])
    recorded = iter(taught)

    def measure(q):
        t = next(recorded)
        if t.point is None:
            raise RoboCalError("the marker was not found in the pair captured")
        return t.point

    at_joints = replace(cell, Q=Q, limits=check_limits(cell.model, cell.unc, Q, [cell.target] * len(Q),
                                                       cell.limits.alpha))
    return job.check(at_joints, measure, log=log, progress=progress, cancelled=cancelled)
