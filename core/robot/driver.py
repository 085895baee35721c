"""The one interface every robot connection implements: the virtual lab's robot
(core.robot.simulated) and serial controllers (core.robot.serial_robot: RoboCal protocol v1
and protocol profiles).

Joint values are in internal units: radians for revolute joints, mm for prismatic ones
(`RobotModel.q_from_file` converts from the degrees of files and screens).

`move_to` returns once the robot has settled at the target (the controller reported done,
or its joints stopped changing); it blocks, so the app calls it on a worker thread, and
`stop()` may come from any thread meanwhile. A connection or controller failure during a
move raises `RobotFault` (the measurement run stops the robot and keeps what it measured).

Safety rules shared by every driver:
- `move_to` refuses a configuration outside the model's joint limits (RoboCalError),
  before anything is sent to the robot;
- `stop()` is always safe to call (connected or not, stopped or not) and latches: no motion
  is accepted after it until `resume()`. The latch and the move share one lock, so once
  `stop()` returns no move is being sent and none will be (a GUI thread's stop cannot fall
  between a worker's check and its move);
- a driver is a context manager (`with driver: ...` connects and always disconnects).
"""
from __future__ import annotations

import threading
from abc import ABC, abstractmethod
from dataclasses import dataclass

import numpy as np

from core.errors import RoboCalError
from core.robot.model import RobotModel


class RobotFault(RoboCalError):
    """The robot or its connection failed (timeout, garbage on the line, disconnect, a
    controller error, a move that ended away from its target). The message is one line."""


class RobotTimeout(RobotFault):
    """A move did not finish in time and the driver's watchdog stopped the robot: a fault, not
    the Stop key, though the robot is stopped afterwards just the same."""


@dataclass(frozen=True)
class DriverInfo:
    """What a connected robot says about itself."""

    name: str
    dof: int
    units: str                     # joint units on the controller side: "deg", "rad" or "ticks"
    can_move: bool = True
    reports_motion_state: bool = True   # done reply or status poll; else joints watched until still
    has_stop: bool = True


class RobotDriver(ABC):
    """A connection to one robot whose nominal geometry and joint limits are `model`."""

    #: shown in the user interface ("Simulated robot", "Serial robot on /dev/ttyUSB0", ...)
    name: str = "robot"

    def __init__(self, model: RobotModel):
        self.model = model
        self._speed = 100.0
        self._motion_lock = threading.Lock()   # the stop latch and a move never interleave
        self._stopped = False

    @property
    def info(self) -> DriverInfo:
        """Name, joint count, controller units and capabilities."""
        return DriverInfo(self.name, self.model.dof, "deg")

    # -- speed ---------------------------------------------------------------------------
    @property
    def speed(self) -> float:
        """Motion speed, percent of the robot's maximum."""
        return self._speed

    def set_speed(self, percent: float) -> None:
        """Set the motion speed (percent, 0 < p <= 100) for the next moves."""
        p = float(percent)
        if not 0 < p <= 100:
            raise RoboCalError(f"speed {percent} % is outside (0, 100]", source=self.name,
                               hint="Give a percentage between 1 and 100.")
        self._apply_speed(p)
        self._speed = p

    def _apply_speed(self, percent: float) -> None:
        """Send the speed to the robot (nothing to send for a robot without one)."""

    # -- connection ----------------------------------------------------------------------
    @property
    @abstractmethod
    def connected(self) -> bool:
        """True between `connect()` and `disconnect()`."""

    @abstractmethod
    def connect(self) -> None:
        """Open the connection (raises RoboCalError naming the device if it cannot)."""

    @abstractmethod
    def disconnect(self) -> None:
        """Close the connection; safe to call twice."""

    # -- motion --------------------------------------------------------------------------
    def move_to(self, q) -> None:
        """Move to joint configuration `q` (internal units). Refuses, with a RoboCalError and
        without moving, a configuration outside the joint limits, a robot that is not
        connected, and a robot that was stopped."""
        q = self.check_joints(q)
        if not self.connected:
            raise RoboCalError("the robot is not connected", source=self.name,
                               hint="Connect it first (Setup step).")
        with self._motion_lock:
            if self._stopped:
                raise RoboCalError("the robot was stopped", source=self.name,
                                   hint="Check that the way is clear, then resume before moving it again.")
            self._move(q)

    @abstractmethod
    def _move(self, q: np.ndarray) -> None:
        """Send a checked configuration to the robot (called by `move_to` only)."""

    @abstractmethod
    def current_joints(self) -> np.ndarray:
        """The joint configuration the robot is in now (internal units), shape (dof,)."""

    def stop(self) -> None:
        """Stop any motion at once and refuse further motion until `resume()`. Never raises
        because the robot is not connected or already stopped. Returns once no move is being
        sent (a move already under way is waited for, then nothing more is sent)."""
        self._halt()
        with self._motion_lock:
            self._stopped = True

    @abstractmethod
    def _halt(self) -> None:
        """Tell the robot to stop now (called by `stop` first, without waiting for a move)."""

    @property
    def stopped(self) -> bool:
        """True after `stop()` until `resume()`."""
        return self._stopped

    def resume(self) -> None:
        """Accept motion again after a stop (the user checked that the way is clear)."""
        with self._motion_lock:
            self._stopped = False

    # -- checks --------------------------------------------------------------------------
    def check_joints(self, q) -> np.ndarray:
        """`q` as a float array of the robot's size, finite and inside the joint limits,
        or a RoboCalError naming the joint, its value and its limits (file units)."""
        return check_joint_values(self.model, q, self.name)

    # -- context manager -----------------------------------------------------------------
    def __enter__(self) -> "RobotDriver":
        self.connect()
        return self

    def __exit__(self, *exc_info) -> None:
        try:
            self.stop()
        finally:
            self.disconnect()


def check_joint_values(model: RobotModel, q, source: str = "robot") -> np.ndarray:
    """`q` (internal units) as a float array of the model's size, finite and inside its joint
    limits, or a RoboCalError naming the joint, its value and its limits (deg / mm)."""
    try:
        q = np.asarray(q, dtype=float).reshape(-1)
    except (TypeError, ValueError) as exc:
        raise RoboCalError(f"joint values must be numbers, got {q!r}", source=source) from exc
    n = model.dof
    if q.shape != (n,):
        raise RoboCalError(f"expected {n} joint values, got {q.size}", source=source)
    lo, hi = model.limits()
    tol = 1e-9
    for i, joint in enumerate(model.joints):
        unit = "°" if joint.revolute else " mm"
        to_file = np.rad2deg if joint.revolute else (lambda v: v)
        label = joint.name or f"J{i + 1}"
        if not np.isfinite(q[i]):
            raise RoboCalError(f"joint {label}: value {q[i]} is not a finite number", source=source)
        if q[i] < lo[i] - tol or q[i] > hi[i] + tol:
            raise RoboCalError(
                f"joint {label}: {to_file(q[i]):.3f}{unit} is outside its limits "
                f"[{to_file(lo[i]):.3f}{unit}, {to_file(hi[i]):.3f}{unit}]; the robot was not moved",
                source=source, hint="Choose a configuration inside the joint limits.")
    return q
