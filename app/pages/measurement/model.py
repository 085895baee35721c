"""Step 5, Measurement, without Qt: what the technician chose (the poses CSV loaded instead of the
project's poses, teach mode, where a taught pose's joints come from), the pose list with the
status of each pose (measured / rejected with the reason / pending / being measured), and the
outcome of the last run (core.measurement.run.MeasurementRunResult).

Points in mm in the left camera frame; joint values in rad / mm (`PoseList.Q`) and as the file
has them, deg / mm (`PoseList.q_file`).

Events of `MeasurementModel` (StepModel): "options", "result", "rows" (every row anew, from
the files), "row" (index: that pose is being measured), "pose" (`PoseShown`: a pose was
measured or rejected).
"""
from __future__ import annotations

from collections import Counter
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from app.jobs.measurement import (MEASURED, PENDING, REJECTED, RUNNING, PoseRow, choose_pose_list, pose_rows,
                                  poses_needed)
from app.pages.step_model import StepModel
from core.measurement.run import MeasurementRunResult, PoseOutcome
from core.poses.file import PoseList


@dataclass(frozen=True)
class MeasurementOptions:
    """The poses CSV the technician loaded instead of the project's poses (None: the project's),
    and whether they chose teach mode (forced anyway when RoboCal cannot move the robot)."""

    loaded_csv: Path | None = None
    teach_chosen: bool = False


@dataclass(frozen=True)
class RunSwitches:
    """The run controls' switches: Teach mode ticked, Pause pressed (wait after the current pose)."""

    teach: bool = False
    paused: bool = False


@dataclass(frozen=True)
class JointSource:
    """Where a taught pose's joint values come from: read from the controller at the capture,
    else `typed` as the pendant shows them (deg / mm, J1 first)."""

    read_from_controller: bool = False
    typed: str = ""


@dataclass(frozen=True)
class PoseShown:
    """A pose just measured or rejected: its row (index into the rows) and the pair's thumbnail
    (an image, or None)."""

    index: int
    row: PoseRow
    thumbnail: np.ndarray | None = None


class MeasurementModel(StepModel[MeasurementOptions, MeasurementRunResult]):
    """The pose list to measure, each pose's status, the minimum for identification (`n_min`),
    and the last run's result."""

    def __init__(self, options: MeasurementOptions | None = None):
        super().__init__(options or MeasurementOptions())
        self.poses: PoseList | None = None
        self.poses_label = ""                  # where the poses come from, in words
        self.n_min = 0
        self.rows: list[PoseRow] = []
        self.file_problem = ""                 # why measurements.csv cannot be used ("" when it can)
        self._row_of: dict[int, int] = {}

    def choose_poses(self, robot, project_poses: Path | None, selection) -> str:
        """The loaded CSV, else the project's poses.csv, else the Pose step's `selection`, with the
        minimum for identification; the problem or "". `robot` None: no pose list (Setup step)."""
        self.poses, self.poses_label = None, ""
        if robot is None:
            return "No project or robot yet (Setup step)."
        self.poses, self.poses_label, problem = choose_pose_list(robot, loaded_csv=self.options.loaded_csv,
                                                                 project_poses=project_poses, selection=selection)
        self.n_min = poses_needed(robot, selection)
        return problem

    def read_rows(self, measurements: Path | None) -> None:
        """Each pose's status from measurements.csv and its rejects file (an earlier run of this list)."""
        self.rows, self.file_problem = pose_rows(self.poses, measurements)
        self._row_of = {r.pose: r.index for r in self.rows}
        self.emit("rows", self.rows)

    def row_of(self, pose: int) -> int | None:
        """The index of the row of pose number `pose`, or None."""
        return self._row_of.get(int(pose))

    def counts(self) -> Counter:
        """How many rows have each status."""
        return Counter(r.status for r in self.rows)

    @property
    def n_measured(self) -> int:
        return sum(1 for r in self.rows if r.status == MEASURED)

    def pending(self) -> list[PoseRow]:
        """The poses still to measure."""
        return [r for r in self.rows if r.status in (PENDING, RUNNING)]

    def next_pose_text(self) -> str:
        pending = self.pending()
        return str(pending[0].pose) if pending else "–"

    def joints(self) -> np.ndarray | None:
        """Every pose's joint values (rad / mm), or None."""
        return self.poses.Q if self.poses is not None else None

    def mark_running(self, pose: int) -> None:
        """Pose number `pose` is being measured."""
        i = self.row_of(pose)
        if i is not None and self.rows[i].status == PENDING:
            self.rows[i].status = RUNNING
            self.emit("row", i)

    def record(self, outcome: PoseOutcome, thumbnail=None) -> None:
        """A pose measured or rejected (a pose of another list is ignored)."""
        i = self.row_of(outcome.pose)
        if i is None:
            return
        r = self.rows[i]
        r.status = MEASURED if outcome.status == MEASURED else REJECTED
        r.reason, r.point, r.sigma = outcome.reason, outcome.point, outcome.sigma
        self.emit("pose", PoseShown(i, r, thumbnail))

    def done_message(self, measurements: Path) -> str:
        """The autopilot's line after the step is done."""
        c = self.counts()
        return (f"{c[MEASURED]} poses measured, {c[REJECTED]} rejected (identification needs {self.n_min}) "
                f"→ {measurements.name}")
