"""The Cartesian targets file `targets.csv` (read by `robocal compensate --targets`, written by
`--for-controller cartesian`).

```
name,x,y,z,roll,pitch,yaw,q1,q2,q3,q4,q5,q6
p1,420.0,-35.5,310.0,180.0,0.0,90.0,10.0,-30.0,45.0,0.0,75.0,10.0
```
One row per target, in the order the robot should visit them. `name` a label (not empty);
`x, y, z` the tool point's position in mm; `roll, pitch, yaw` (optional, all three or none) its
orientation in degrees, R = Rz(yaw)·Ry(pitch)·Rx(roll) as robot.json's rpy; without them the
targets are positions only. `q1 … qn` (optional, all or none, degrees / mm for prismatic
joints): the joints the robot should stay near (a taught program's), which choose the branch of
the solution. Columns may come in any order; lines starting with `#` and blank lines are
ignored. The frame of the targets is not in the file: the command says it (--frame).
"""
from __future__ import annotations

import csv
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from core import transforms as tf
from core.bounds import ANGLE_DEG, LENGTH_MM
from core.errors import RoboCalError
from core.files import atomic_write_text, read_text

POSITION = ("x", "y", "z")
ORIENTATION = ("roll", "pitch", "yaw")


@dataclass
class TargetList:
    """Targets read from a file: `names` (N,), `xyz` (N, 3) mm, `rpy_deg` (N, 3) or None,
    `hint_file` (N, n) joints in file units (deg / mm) or None; `path` the file."""

    names: list[str]
    xyz: np.ndarray
    rpy_deg: np.ndarray | None = None
    hint_file: np.ndarray | None = None
    path: Path | None = None

    def __len__(self) -> int:
        return len(self.names)

    @property
    def rotations(self) -> np.ndarray | None:
        """The orientations (N, 3, 3), or None for position-only targets."""
        if self.rpy_deg is None:
            return None
        return np.array([tf.rpy_to_matrix(np.deg2rad(r)) for r in self.rpy_deg]).reshape(-1, 3, 3)


def _joint_columns(header: list[str]) -> list[str]:
    qs = [c for c in header if c[:1] == "q" and c[1:].isdigit()]
    return sorted(qs, key=lambda c: int(c[1:]))


def read_targets(path: str | Path, dof: int | None = None) -> TargetList:
    """Read a targets file; with `dof`, hint columns must be q1 … q<dof>. RoboCalError naming
    the file, line and column otherwise."""
    path = Path(path)
    text = read_text(path, "a targets CSV file")
    header: list[str] | None = None
    names, rows = [], []
    hint = "The header is name,x,y,z[,roll,pitch,yaw][,q1,...,qn] (mm, degrees)."
    for line_no, raw in enumerate(text.splitlines(), start=1):
        line = raw.strip()
        if not line or line.startswith("#"):
            continue
        try:
            cells = [c.strip() for c in next(csv.reader([line]))]
        except csv.Error as exc:
            raise RoboCalError(f"line {line_no}: unreadable row ({exc})", source=path,
                               hint="Check the row; is this a CSV file?") from None
        if header is None:
            header = cells
            missing = [c for c in ("name",) + POSITION if c not in header]
            if missing:
                raise RoboCalError(f"line {line_no}: the header has no column '{missing[0]}'", source=path,
                                   hint=hint)
            given = [c for c in ORIENTATION if c in header]
            if given and len(given) < 3:
                absent = [c for c in ORIENTATION if c not in header][0]
                raise RoboCalError(f"line {line_no}: the header has {', '.join(given)} but no column '{absent}'",
                                   source=path, hint="Give roll, pitch and yaw together, or none of them.")
            qs = _joint_columns(header)
            if qs and [int(c[1:]) for c in qs] != list(range(1, len(qs) + 1)):
                raise RoboCalError(f"line {line_no}: the joint columns must be q1 … qn without a gap", source=path,
                                   hint=hint)
            if qs and dof is not None and len(qs) != dof:
                raise RoboCalError(f"line {line_no}: the file has {len(qs)} joint columns but the robot has {dof} "
                                   "joints", source=path, hint="Give q1 … qn for every joint, or no joint columns.")
            unknown = [c for c in header if c not in ("name",) + POSITION + ORIENTATION and c not in qs]
            if unknown or len(set(header)) != len(header):
                bad = unknown[0] if unknown else next(c for c in header if header.count(c) > 1)
                raise RoboCalError(f"line {line_no}: unexpected or repeated column '{bad}'", source=path, hint=hint)
            continue
        if len(cells) != len(header):
            raise RoboCalError(f"line {line_no}: expected {len(header)} values, got {len(cells)}", source=path,
                               hint="Check for a missing or extra comma.")
        row = {}
        for col, cell in zip(header, cells):
            if col == "name":
                if not cell:
                    raise RoboCalError(f"line {line_no}, column 'name': empty", source=path,
                                       hint="Give every target a name.")
                row[col] = cell
                continue
            try:
                v = float(cell)
            except ValueError:
                raise RoboCalError(f"line {line_no}, column '{col}': expected a number, got '{cell}'",
                                   source=path) from None
            if not math.isfinite(v):
                raise RoboCalError(f"line {line_no}, column '{col}': expected a finite number", source=path)
            (ANGLE_DEG if col in ORIENTATION else LENGTH_MM).check(v, source=path, field=f"line {line_no}, {col}")
            row[col] = v
        names.append(row["name"])
        rows.append(row)
    if header is None:
        raise RoboCalError("empty file (no header)", source=path, hint=hint)
    if not rows:
        raise RoboCalError("no targets (only a header)", source=path, hint="Add one row per target.")
    xyz = np.array([[r[c] for c in POSITION] for r in rows], dtype=float)
    rpy = np.array([[r[c] for c in ORIENTATION] for r in rows], dtype=float) if "roll" in header else None
    qs = _joint_columns(header)
    hint_file = np.array([[r[c] for c in qs] for r in rows], dtype=float) if qs else None
    return TargetList(names, xyz, rpy, hint_file, path)


def _num(v: float) -> str:
    return f"{0.0 if abs(v) < 5e-7 else v:.6f}"


def format_targets(names, xyz, rpy_deg=None, hint_file=None) -> str:
    """The text of a targets file (6 decimals: a micrometre and a micro-degree)."""
    xyz = np.asarray(xyz, dtype=float).reshape(-1, 3)
    cols = ["name", *POSITION]
    if rpy_deg is not None:
        cols += list(ORIENTATION)
    if hint_file is not None:
        cols += [f"q{j + 1}" for j in range(np.shape(hint_file)[1])]
    lines = [",".join(cols)]
    for i, name in enumerate(names):
        if any(c in str(name) for c in ',"\n\r') or not str(name).strip() or str(name).startswith("#"):
            raise RoboCalError(f"target name {name!r} cannot be written to a CSV cell",
                               hint="Use names without commas, quotes or line breaks.")
        values = list(xyz[i])
        if rpy_deg is not None:
            values += list(np.asarray(rpy_deg, dtype=float)[i])
        if hint_file is not None:
            values += list(np.asarray(hint_file, dtype=float)[i])
        lines.append(",".join([str(name)] + [_num(v) for v in values]))
    return "\n".join(lines) + "\n"


def write_targets(path: str | Path, names, xyz, rpy_deg=None, hint_file=None) -> Path:
    """Write a targets file atomically."""
    return atomic_write_text(path, format_targets(names, xyz, rpy_deg, hint_file))
