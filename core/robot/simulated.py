"""A simulated robot: the robot connection of the virtual lab.

It is one driver among the others (core.robot.driver): it moves instantly to any configuration inside the joint limits of its `RobotModel` (for the
virtual lab, the robot's *true* geometry; the nominal model is what the user calibrates).
"""
from __future__ import annotations

import threading

import numpy as np

from core.robot.model import RobotModel
from core.robot.driver import DriverInfo, RobotDriver


class SimulatedRobot(RobotDriver):
    name = "Simulated robot (virtual lab)"

    def __init__(self, model: RobotModel, q0=None):
        super().__init__(model)
        lo, hi = model.limits()
        start = np.zeros(model.dof) if q0 is None else np.asarray(q0, dtype=float).reshape(-1)
        self._q = self.check_joints(np.clip(start, lo, hi) if q0 is None else start)
        self._connected = False
        self._lock = threading.Lock()   # current_joints() may come from the GUI thread during a move
        self.stop_count = 0
        self.move_count = 0

    @property
    def info(self) -> DriverInfo:
        return DriverInfo(self.name, self.model.dof, "rad")

    @property
    def connected(self) -> bool:
        return self._connected

    def connect(self) -> None:
        self._connected = True

    def disconnect(self) -> None:
        self._connected = False

    def _move(self, q: np.ndarray) -> None:
        with self._lock:
            self._q = q.copy()
            self.move_count += 1

    def current_joints(self) -> np.ndarray:
        with self._lock:
            return self._q.copy()

    def pose(self) -> np.ndarray:
        """Tool pose (4x4, mm) of the current configuration in the model's world frame."""
        return self.model.fk(self.current_joints())

    def _halt(self) -> None:
        self.stop_count += 1
