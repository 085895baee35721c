"""The Compensation step's model, without Qt: what the technician chose (a point and its frame, the
model Go to point uses, the targets of the accuracy map), the calibrated robot of the project, the
points computed with it, and the accuracy map measured (the step's result).

Events: "options", "result" (a `MeasuredMap`, or None when cleared) and "points" (the points
changed; the value is the row to select, or None).
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from app.jobs import compensation as job
from app.pages.step_model import StepModel
from core.project import Output

FRAMES = ("base", "camera", "fixture")      # robot base frame, left camera frame, located fixture


@dataclass(frozen=True)
class PointOptions:
    """A typed point (mm) in `frame` (one of FRAMES), and whether Go to point uses the nominal
    model instead of the calibrated one."""

    point: tuple[float, float, float] = (0.0, 0.0, 0.0)
    frame: str = "base"
    nominal: bool = False


@dataclass(frozen=True)
class CompensationOptions:
    """The Points panel's choices and how many targets the accuracy map has."""

    points: PointOptions = PointOptions()
    map_targets: int = 20


@dataclass(frozen=True)
class MeasuredMap:
    """An accuracy map (core.compensation.accuracy_map.AccuracyMap) and the file it was written
    to or read from (None: nothing written)."""

    amap: object
    path: Path | None = None


class CompensationModel(StepModel[CompensationOptions, MeasuredMap]):
    """The page's state: options, the calibrated cell, the computed points and the map."""

    def __init__(self, options: CompensationOptions | None = None):
        super().__init__(options or CompensationOptions())
        self.cell: job.Cell | None = None
        self.points: list[job.CompensatedPoint] = []
        self._cell_key: tuple | None = None

    # -- the calibrated cell ----------------------------------------------------------------
    @staticmethod
    def ready(project, robot) -> bool:
        """The project has a calibrated robot (calibrated.json) and a nominal one is loaded."""
        return project is not None and project.path(Output.CALIBRATED).is_file() and robot is not None

    def load_cell(self, project, robot) -> job.Cell | None:
        """The calibrated robot of the project (read again when calibrated.json or the measurements
        changed: the points computed with another calibration are cleared); None when not ready.
        RoboCalError when calibrated.json cannot be read."""
        if not self.ready(project, robot):
            self.cell = self._cell_key = None
            return None
        path, meas = project.path(Output.CALIBRATED), project.path(Output.MEASUREMENTS)
        key = (str(path), path.stat().st_mtime_ns, id(robot), meas.is_file() and meas.stat().st_mtime_ns)
        if key != self._cell_key:
            if self.points:
                self.clear_points()
            self.cell, self._cell_key = job.load_cell(path, robot, meas), key
        return self.cell

    def forget(self) -> None:
        """Another project or robot: no cell, no points, no map (listeners hear the map cleared)."""
        self.cell = self._cell_key = None
        self.set_result(None)
        self.clear_points()

    def q_file(self, q) -> np.ndarray:
        """Joints (rad / mm) as the files write them (deg / mm)."""
        return self.cell.calibrated.q_to_file(q) if self.cell is not None else np.rad2deg(q)

    # -- points -----------------------------------------------------------------------------
    def add_points(self, points: list[job.CompensatedPoint]) -> list[job.CompensatedPoint]:
        self.points.extend(points)
        self.emit("points", len(self.points) - 1)
        return points

    def replace_point(self, row: int, point: job.CompensatedPoint) -> job.CompensatedPoint:
        self.points[row] = point
        self.emit("points", row)
        return point

    def clear_points(self) -> None:
        self.points = []
        self.emit("points", None)
