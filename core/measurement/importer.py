"""Measurements from other tools: CSV files of joint values and measured positions (laser
trackers, CMMs, another calibration tool) turned into RoboCal's measurements file.

Columns are recognised by name in any order (case, spaces and dashes do not matter):

- pose id:   ``pose``, ``pose_id``, ``id``, ``config``, ``configuration``, ``sample``  (optional:
  without it, consecutive rows with the same joint values are one pose)
- target:    ``target``, ``point``, ``reflector``, ``smr``, ``marker``, ``target_name``  (optional:
  without it every row measures the target named by the caller, ``marker`` by default)
- joints:    ``q1``…, ``j1``…, ``joint1``/``joint_1``…, ``theta1``…, ``axis1``…
- position:  ``x y z``, ``px py pz``, ``pos_x``…, ``position_x``…, ``tx ty tz``

A unit suffix on a column (``q1_deg``, ``q1_rad``, ``x_mm``, ``x_m``) says its unit; otherwise the
units given by the caller apply (mm and degrees by default). A suffix that contradicts the
caller's unit is refused rather than guessed about. Positions read as mm because nothing said
otherwise that look like metres (spanning under 20 mm over three or more poses) are refused
with the unit to give. Comma, semicolon and tab separated files are read; ``#`` lines are comments.
"""
from __future__ import annotations

import csv
import io
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Sequence

import numpy as np

from core.bounds import ANGLE_DEG, LENGTH_MM, POINT_COUNT, POSE_ID
from core.errors import RoboCalError
from core.files import read_text
from core.measurement.file import Measurements
from core.robot.model import RobotModel

LENGTH_UNITS = {"mm": 1.0, "m": 1000.0}
MIN_SPAN_MM = 20.0              # positions read as mm spanning less than this over 3+ poses: metres, not mm
ANGLE_UNITS = {"deg": 1.0, "rad": 180.0 / np.pi}

_POSE = re.compile(r"^(pose|pose_?id|id|config|configuration|sample)$")
_TARGET = re.compile(r"^(target|point|reflector|smr|marker|target_?name)$")
_JOINT = re.compile(r"^(?:q|j|joint|theta|axis)_?(\d+)(?:_(deg|rad|mm|m))?$")
_XYZ = re.compile(r"^(?:p|pos_?|position_?|t)?([xyz])(?:_(mm|m))?$")


@dataclass
class ImportedMeasurements:
    """What an import gives: the measurements (file units: deg / mm, mm) and what was assumed."""

    measurements: Measurements
    sources: list[Path]
    notes: list[str] = field(default_factory=list)


def _normalise(name: str) -> str:
    return re.sub(r"[\s\-]+", "_", name.strip().lower())


def _rows(path: Path) -> tuple[list[str], list[tuple[int, list[str]]]]:
    """Header and data rows (line number, cells) of a delimited text file."""
    text = read_text(path, "a CSV file of joint values and positions")
    lines = [(i, ln) for i, ln in enumerate(io.StringIO(text), start=1) if ln.strip() and not ln.lstrip().startswith("#")]
    if not lines:
        raise RoboCalError("the file has no header and no rows", source=path,
                           hint="Give a CSV file with a header line (pose, q1..qn, x, y, z).")
    sample = "".join(ln for _, ln in lines[:5])
    delimiter = max(",;\t", key=sample.count)
    rows = []
    for line_no, line in lines:
        try:
            rows.append((line_no, [c.strip() for c in next(csv.reader([line], delimiter=delimiter))]))
        except csv.Error as exc:
            raise RoboCalError(f"line {line_no}: unreadable row ({exc})", source=path) from None
        if len(rows) > POINT_COUNT.hi + 1:
            raise RoboCalError(f"more than {POINT_COUNT.hi:,.0f} rows ({POINT_COUNT.reason})", source=path)
    return rows[0][1], rows[1:]


def _unit(path: Path, column: str, suffix: str | None, given: str | None, default: str, kind: str) -> str:
    if suffix and given and suffix != given:
        raise RoboCalError(f"the column says {suffix} but the {kind} unit given is {given}", source=path,
                           field=column, hint=f"Give the {kind} unit the file uses, or none.")
    return suffix or given or default


def _layout(path: Path, header: list[str]) -> dict:
    names = [_normalise(h) for h in header]
    layout: dict = {"pose": None, "target": None, "joints": {}, "xyz": {}}
    for i, name in enumerate(names):
        if _POSE.match(name) and layout["pose"] is None:
            layout["pose"] = i
        elif _TARGET.match(name) and layout["target"] is None:
            layout["target"] = i
        elif m := _JOINT.match(name):
            k = int(m.group(1))
            if k in layout["joints"]:
                raise RoboCalError(f"two columns for joint {k} ('{header[layout['joints'][k][0]]}', '{header[i]}')",
                                   source=path, hint="Keep one column per joint.")
            layout["joints"][k] = (i, m.group(2))
        elif m := _XYZ.match(name):
            axis = m.group(1)
            if axis in layout["xyz"]:
                raise RoboCalError(f"two columns for {axis} ('{header[layout['xyz'][axis][0]]}', '{header[i]}')",
                                   source=path, hint="Keep one column per coordinate.")
            layout["xyz"][axis] = (i, m.group(2))
    joints = sorted(layout["joints"])
    if not joints:
        raise RoboCalError("no joint columns found (q1, q2, … or j1, joint1, …)", source=path,
                           hint=f"The header is: {', '.join(header)}")
    if joints != list(range(1, len(joints) + 1)):
        raise RoboCalError(f"the joint columns must be numbered 1..{len(joints)}, found {joints}", source=path)
    missing = [a for a in "xyz" if a not in layout["xyz"]]
    if missing:
        raise RoboCalError(f"no column for {', '.join(missing)} (x, y, z or x_mm, … )", source=path,
                           hint=f"The header is: {', '.join(header)}")
    return layout


def _number(path: Path, line_no: int, column: str, text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise RoboCalError(f"line {line_no}: expected a number, got {text!r}", source=path, field=column) from None
    if not np.isfinite(value):
        raise RoboCalError(f"line {line_no}: expected a finite number, got {text!r}", source=path, field=column)
    return value


def import_measurements(paths: Sequence[str | Path], *, length_unit: str | None = None,
                        angle_unit: str | None = None, target: str = "marker",
                        robot: RobotModel | None = None) -> ImportedMeasurements:
    """Read one or more CSV files (see the module docstring) as one set of measurements.

    `length_unit` ("mm" or "m") applies to positions and prismatic joints, `angle_unit`
    ("deg" or "rad") to revolute joints (all joints when no `robot` says which are prismatic),
    where a column's own suffix does not say. Pose ids must not repeat across files."""
    for unit, allowed, kind in ((length_unit, LENGTH_UNITS, "length"), (angle_unit, ANGLE_UNITS, "angle")):
        if unit is not None and unit not in allowed:
            raise RoboCalError(f"unknown {kind} unit '{unit}'", hint=f"Use one of: {', '.join(allowed)}.")
    poses: list[int] = []
    targets: list[str] = []
    q_rows: list[np.ndarray] = []
    xyz_rows: list[np.ndarray] = []
    lines: list[int] = []
    notes: list[str] = []
    sources = [Path(p) for p in paths]
    dof = None
    used_ids: dict[int, Path] = {}
    said_length = True                  # every position column's unit given (by the caller or its suffix)
    for path in sources:
        header, rows = _rows(path)
        layout = _layout(path, header)
        n = len(layout["joints"])
        if dof is not None and n != dof:
            raise RoboCalError(f"{n} joint columns, but {sources[0].name} has {dof}", source=path)
        if robot is not None and n != robot.dof:
            raise RoboCalError(f"{n} joint columns, but the robot '{robot.name}' has {robot.dof} joints", source=path,
                               hint="Use the robot these measurements were taken with.")
        dof = n
        revolute = robot.revolute_mask() if robot is not None else np.ones(n, dtype=bool)
        scale = np.empty(n)
        for k in range(1, n + 1):
            col, suffix = layout["joints"][k]
            if revolute[k - 1]:
                unit = _unit(path, header[col], suffix if suffix in ANGLE_UNITS else None, angle_unit, "deg", "angle")
                if suffix in LENGTH_UNITS:
                    raise RoboCalError(f"column '{header[col]}' is a length but joint {k} is revolute", source=path)
                scale[k - 1] = ANGLE_UNITS[unit]
            else:
                unit = _unit(path, header[col], suffix if suffix in LENGTH_UNITS else None, length_unit, "mm", "length")
                scale[k - 1] = LENGTH_UNITS[unit]
        xyz_scale = {a: LENGTH_UNITS[_unit(path, header[c], s, length_unit, "mm", "length")]
                     for a, (c, s) in layout["xyz"].items()}
        said_length = said_length and (length_unit is not None or all(s for _, s in layout["xyz"].values()))
        if layout["pose"] is None:
            notes.append(f"{path.name}: no pose column; consecutive rows with the same joint values are one pose")
        if layout["target"] is None:
            notes.append(f"{path.name}: no target column; every row measures '{target}'")
        next_id = max(used_ids, default=-1) + 1
        file_ids: dict[int, np.ndarray] = {}
        last_q = None
        for line_no, cells in rows:
            if len(cells) != len(header):
                raise RoboCalError(f"line {line_no}: {len(cells)} values, the header has {len(header)}", source=path,
                                   hint="Check for a missing or extra separator.")
            q = np.array([_number(path, line_no, header[layout["joints"][k][0]], cells[layout["joints"][k][0]])
                          for k in range(1, n + 1)]) * scale
            for k in range(n):
                (ANGLE_DEG if revolute[k] else LENGTH_MM).check(q[k], source=path,
                                                                field=f"line {line_no}, {header[layout['joints'][k + 1][0]]}")
            xyz = np.array([_number(path, line_no, header[layout["xyz"][a][0]], cells[layout["xyz"][a][0]])
                            * xyz_scale[a] for a in "xyz"])
            for a, v in zip("xyz", xyz):
                LENGTH_MM.check(v, source=path, field=f"line {line_no}, {header[layout['xyz'][a][0]]}")
            if layout["pose"] is not None:
                text = cells[layout["pose"]]
                try:
                    pid = int(text)
                except ValueError:
                    raise RoboCalError(f"line {line_no}: expected a whole number as pose id, got {text!r}",
                                       source=path, field=header[layout["pose"]]) from None
                POSE_ID.check(pid, source=path, field=f"line {line_no}, {header[layout['pose']]}")
            else:
                if last_q is None or np.max(np.abs(q - last_q)) > 1e-9:
                    next_id += 1 if last_q is not None else 0
                pid = next_id
            last_q = q
            if pid in used_ids and used_ids[pid] != path:
                raise RoboCalError(f"line {line_no}: pose {pid} is also in {used_ids[pid].name}", source=path,
                                   hint="Give the poses of each file their own numbers.")
            if pid in file_ids and np.max(np.abs(file_ids[pid] - q)) > 1e-6:
                raise RoboCalError(f"line {line_no}: pose {pid} has other joint values than on an earlier line",
                                   source=path, hint="One pose, one set of joint values.")
            file_ids[pid] = q
            name = cells[layout["target"]] if layout["target"] is not None else target
            if not name:
                raise RoboCalError(f"line {line_no}: empty target name", source=path, field=header[layout["target"]])
            poses.append(pid)
            targets.append(name)
            q_rows.append(q)
            xyz_rows.append(xyz)
            lines.append(line_no)
        used_ids.update({pid: path for pid in file_ids})
        if not file_ids:
            raise RoboCalError("the file has a header but no rows", source=path)
    seen: dict[tuple[int, str], int] = {}
    for i, key in enumerate(zip(poses, targets)):
        if key in seen:
            raise RoboCalError(f"pose {key[0]} target '{key[1]}' appears twice (lines {seen[key]} and {lines[i]})",
                               source=sources[0] if len(sources) == 1 else None, hint="Remove the duplicate row.")
        seen[key] = lines[i]
    meas = Measurements(pose=np.array(poses), target=targets, q_file=np.array(q_rows), xyz=np.array(xyz_rows),
                        line=np.array(lines), source=", ".join(str(p) for p in sources))
    if not said_length:
        _check_millimetres(meas, sources)
    return ImportedMeasurements(meas, sources, notes)


def _extent(P: np.ndarray) -> float:
    """The largest side of the box around points P (N, 3)."""
    return float(np.max(P.max(axis=0) - P.min(axis=0))) if len(P) else 0.0


def _check_millimetres(meas: Measurements, sources: list[Path]) -> None:
    """Positions read as mm (no unit said) that span under MIN_SPAN_MM over three or more poses
    are metres: a robot's measured points span hundreds of millimetres."""
    span = _extent(meas.xyz)
    if meas.n_poses >= 3 and span < MIN_SPAN_MM:
        raise RoboCalError(f"the positions span only {span:.4g} (read as mm) over {meas.n_poses} poses: "
                           "they look like metres", source=sources[0] if len(sources) == 1 else None,
                           field="x, y, z", hint="Give --length-unit m, or name the columns x_m, y_m, z_m.")
