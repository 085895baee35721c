"""The pose sequence file `poses.csv` (written by pose selection, read by the Measurement step).

```
pose,q1,q2,q3,q4,q5,q6
0,12.345,-40.000,33.100,0.000,45.250,-90.000
```
One row per pose in the order the robot should visit them; `pose` numbers them 0, 1, …;
joint values in file units (degrees for revolute joints, mm for prismatic ones), 3 decimals
(the layout of the virtual-lab dataset's `poses/joints.csv`). Lines starting with `#` and blank
lines are ignored when reading. Writing is atomic.
"""
from __future__ import annotations

import csv
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from core.bounds import ANGLE_DEG, LENGTH_MM, POSE_ID, Bound
from core.errors import RoboCalError
from core.files import atomic_write_text, read_text
from core.robot.model import RobotModel


@dataclass
class PoseList:
    """Poses read from a file: `q_file` (N, n) in deg / mm, `Q` (N, n) internal (rad / mm) when
    read with a robot, `pose` (N,) the pose numbers, `path` the file."""

    q_file: np.ndarray
    Q: np.ndarray | None
    pose: np.ndarray
    path: Path | None = None

    def __len__(self) -> int:
        return len(self.q_file)


#: a joint value when the robot (and so the joint's unit) is not known
JOINT_VALUE = Bound(-1e5, 1e5, "", "joint values are degrees or mm; 100 000 of either is no joint's")


def format_poses(q_file, decimals: int = 3) -> str:
    """The text of poses.csv for joint values (N, n) in file units (`decimals` after the point:
    3 for selected poses, 6 for corrected programs whose joints matter to the micro-degree)."""
    q = np.atleast_2d(np.asarray(q_file, dtype=float))
    header = "pose," + ",".join(f"q{j + 1}" for j in range(q.shape[1]))
    rows = [f"{i}," + ",".join(f"{0.0 if v == 0 else v:.{decimals}f}" for v in row)
            for i, row in enumerate(q)]
    return "\n".join([header] + rows) + "\n"


def write_poses(path: str | Path, q_file, decimals: int = 3) -> Path:
    """Write poses.csv atomically (joint values (N, n) in deg / mm)."""
    return atomic_write_text(path, format_poses(q_file, decimals))


def read_poses(path: str | Path, robot: RobotModel | None = None) -> PoseList:
    """Read poses.csv; with `robot`, check the joint count and the limits and convert to
    internal units. Errors name the file and line and say what to do."""
    path = Path(path)
    text = read_text(path, "a poses CSV file")
    header = None
    poses, rows = [], []
    for line_no, raw in enumerate(text.splitlines(), start=1):
        line = raw.strip()
        if not line or line.startswith("#"):
            continue
        try:
            cells = [c.strip() for c in next(csv.reader([line]))]
        except csv.Error as exc:              # e.g. a field over the csv module's 128 KiB limit
            raise RoboCalError(f"line {line_no}: unreadable row ({exc})", source=path,
                               hint="Check the row; is this a CSV file?") from None
        if header is None:
            n = len(cells) - 1
            if cells[0] != "pose" or n < 1 or cells[1:] != [f"q{j + 1}" for j in range(n)]:
                raise RoboCalError(f"line {line_no}: the header must be pose,q1,...,qn", source=path,
                                   hint="Is this a RoboCal poses file?")
            if robot is not None and n != robot.dof:
                raise RoboCalError(f"line {line_no}: the file has {n} joint columns but the robot "
                                   f"'{robot.name}' has {robot.dof} joints", source=path,
                                   hint="Use the robot model these poses were selected for.")
            header = cells
            bounds = ([ANGLE_DEG if j.revolute else LENGTH_MM for j in robot.joints] if robot is not None
                      else [JOINT_VALUE] * n)
            continue
        if len(cells) != len(header):
            raise RoboCalError(f"line {line_no}: expected {len(header)} values, got {len(cells)}",
                               source=path, hint="Check for a missing or extra comma.")
        values = []
        for name, c in zip(header, cells):
            try:
                v = float(c)
            except ValueError:
                raise RoboCalError(f"line {line_no}, column '{name}': expected a number, got '{c}'",
                                   source=path) from None
            if not math.isfinite(v):
                raise RoboCalError(f"line {line_no}, column '{name}': expected a finite number",
                                   source=path)
            (POSE_ID if name == "pose" else bounds[len(values) - 1]).check(v, source=path,
                                                                           field=f"line {line_no}, {name}")
            values.append(v)
        poses.append(int(values[0]) if float(values[0]).is_integer() else -1)
        if poses[-1] < 0:
            raise RoboCalError(f"line {line_no}, column 'pose': expected a whole number", source=path)
        rows.append(values[1:])
    if header is None:
        raise RoboCalError("empty file (no header)", source=path, hint="A poses file starts with 'pose,q1,...'.")
    q_file = np.array(rows, dtype=float).reshape(len(rows), len(header) - 1)
    Q = None
    if robot is not None:
        Q = robot.q_from_file(q_file).reshape(q_file.shape)
        lo, hi = robot.limits()
        tol = 1e-6
        bad = np.argwhere((Q < lo - tol) | (Q > hi + tol))
        if len(bad):
            i, j = (int(v) for v in bad[0])
            raise RoboCalError(f"pose {poses[i]}: q{j + 1} = {q_file[i, j]:g} is outside the joint limits "
                               f"of '{robot.name}'", source=path,
                               hint="Select the poses again for this robot.")
    return PoseList(q_file=q_file, Q=Q, pose=np.array(poses, dtype=int), path=path)



def read_pose_list(path: str | Path, robot: RobotModel) -> PoseList:
    """A poses CSV to measure with `robot`: joint values converted to internal units (rad / mm)
    in `Q`. Unlike `read_poses(path, robot)`, poses outside the joint limits are kept: the robot
    refuses them one by one and the measurement run reports them."""
    poses = read_poses(path)
    if poses.q_file.shape[1] != robot.dof:
        raise RoboCalError(f"the file has {poses.q_file.shape[1]} joint columns but the robot '{robot.name}' "
                           f"has {robot.dof} joints", source=path, hint="Use poses selected for this robot.")
    poses.Q = np.asarray(robot.q_from_file(poses.q_file), dtype=float).reshape(poses.q_file.shape)
    return poses
