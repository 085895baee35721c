"""The check log `checks.csv` (format robocal.checks/1): append-only, one row per check point,
flushed and synced per row so that a check killed half-way loses nothing it measured.

```
# robocal.checks/1 ; check points against the calibrated model; an overall row closes each check
run,time,kind,pose,target,q1,...,qn,x,y,z,px,py,pz,error_mm,limit_mm,within,tool,cxx,cxy,cxz,cyy,cyz,czz
20250101T101500Z,2025-01-01T10:15:03+00:00,point,0,marker,10.000,...,412.310,-20.550,815.020,412.1,-20.4,815.3,0.392,0.611,1,gripper,1.2e-05,3.1e-07,-2e-06,1.1e-05,4e-07,9.8e-05
20250101T101500Z,2025-01-01T10:15:40+00:00,overall,,,,...,,,,,,,0.402,0.455,1,gripper,,,,,,
```
`run` names one check (all its rows), `time` is ISO 8601 UTC. A `point` row: joint values in
deg / mm, measured x, y, z and predicted px, py, pz in mm (measurement frame), the error
length and its limit (mm), `within` 1 or 0. An `overall` row: the RMS error over the check's
points and its limit (mm). `tool`: the tool mounted for the check (the robot file's tool name).
`cxx … czz`: the measured point's own covariance (mm², measurement frame; its six distinct
entries) when the instrument gave one (the marker located in a pair), else empty: a later
re-identification from the log judges the point as the check did. A log written before the
`tool` or the covariance columns existed reads as it is (no tools, no covariances); appending to
it first rewrites it (atomically) in the present layout, its rows kept with those columns empty.
A row cut short by a crash is ignored when read and cut off before the next append.
"""
from __future__ import annotations

import csv
import io
import math
import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from core.errors import RoboCalError
from core.files import atomic_write_text, drop_partial_last_line, ensure_writable_dir, read_text, require_regular_file
from core.measurement.point import usable_covariance

FAMILY = "robocal.checks"
FORMAT = f"{FAMILY}/1"
TAG = f"# {FORMAT} ; check points against the calibrated model; an overall row closes each check"
POINT, OVERALL = "point", "overall"
COVARIANCE = ["cxx", "cxy", "cxz", "cyy", "cyz", "czz"]
_UPPER = [(0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2)]       # the entries COVARIANCE names


def header_columns(dof: int, tool: bool = True, covariance: bool = True) -> list[str]:
    """The header for n joints; `tool` / `covariance` False: the layouts before those columns
    (a log without the tool column has no covariance columns either)."""
    return (["run", "time", "kind", "pose", "target"] + [f"q{i + 1}" for i in range(dof)]
            + ["x", "y", "z", "px", "py", "pz", "error_mm", "limit_mm", "within"] + (["tool"] if tool else [])
            + (COVARIANCE if tool and covariance else []))


@dataclass
class LoggedPoint:
    pose: int
    target: str
    q_file: np.ndarray
    measured: np.ndarray
    predicted: np.ndarray
    error_mm: float
    limit_mm: float
    within: bool
    time: str = ""
    tool: str = ""
    covariance: np.ndarray | None = None     # (3, 3) mm², the measurement's own


@dataclass
class LoggedCheck:
    """One check run as logged: its points and, when it finished, the overall RMS and limit."""

    run: str
    time: str = ""
    points: list[LoggedPoint] = field(default_factory=list)
    rms_mm: float | None = None
    rms_limit_mm: float | None = None
    within: bool | None = None
    tool: str = ""

    @property
    def finished(self) -> bool:
        return self.rms_mm is not None


@dataclass
class CheckLog:
    checks: list[LoggedCheck]
    dof: int
    path: Path | None = None
    tool_column: bool = True        # False for a log written before the tool column
    covariance_columns: bool = True  # False for a log written before the covariance columns


def _fmt(v: float) -> str:
    return f"{0.0 if v == 0 else v:.4f}"


class CheckLogWriter:
    """Appends rows to a check log; creates it with its tag and header when new, and rewrites a log
    of an earlier layout in the present one first."""

    def __init__(self, path: str | Path, dof: int):
        self.path = Path(path)
        self.dof = int(dof)
        require_regular_file(self.path)
        ensure_writable_dir(self.path.parent if str(self.path.parent) else Path("."))
        new = not self.path.exists() or self.path.stat().st_size == 0
        if not new:
            existing = read_check_log(self.path)        # refused here, the file is left as it was
            if existing.dof != self.dof:
                raise RoboCalError(f"the log holds checks of a robot with {existing.dof} joints, not {self.dof}",
                                   source=self.path, field="header", hint="Give another check log file.")
            drop_partial_last_line(self.path)           # only a check log's own cut-off row
            if not (existing.tool_column and existing.covariance_columns):
                _upgrade_layout(self.path, existing)
        try:
            self._handle = open(self.path, "a", encoding="utf-8", newline="")
        except OSError as exc:
            raise RoboCalError(f"cannot open the check log ({exc.strerror})", source=self.path,
                               hint="Check the folder's permissions.") from exc
        if new:
            self._write(TAG + "\n" + ",".join(header_columns(self.dof)) + "\n")

    def _write(self, text: str) -> None:
        try:
            self._handle.write(text)
            self._handle.flush()
            os.fsync(self._handle.fileno())
        except OSError as exc:
            raise RoboCalError(f"cannot write the check log ({exc.strerror})", source=self.path,
                               hint="Check the disk space.") from exc

    def _row(self, values: list[str], tool: str, covariance=None) -> None:
        cov = [""] * 6 if covariance is None else [f"{covariance[i, j]:.8g}" for i, j in _UPPER]
        self._write(",".join(values + [tool] + cov) + "\n")

    def point(self, run: str, time: str, pose: int, target: str, q_file, measured, predicted,
              error_mm: float, limit_mm: float, within: bool, tool: str = "", covariance=None) -> None:
        """One check point; `covariance` (3, 3) mm²: the measurement's own, or None (also for a
        matrix that is no covariance, core.measurement.point.usable_covariance)."""
        values = [run, time, POINT, str(int(pose)), target] + [f"{v:.3f}" for v in np.asarray(q_file, float)] \
            + [_fmt(v) for v in measured] + [_fmt(v) for v in predicted] \
            + [_fmt(error_mm), _fmt(limit_mm), "1" if within else "0"]
        self._row(values, tool, usable_covariance(covariance))

    def overall(self, run: str, time: str, rms_mm: float, limit_mm: float, within: bool, tool: str = "") -> None:
        values = [run, time, OVERALL, "", ""] + [""] * (self.dof + 6) + [_fmt(rms_mm), _fmt(limit_mm),
                                                                      "1" if within else "0"]
        self._row(values, tool)

    def close(self) -> None:
        if not self._handle.closed:
            self._handle.close()

    def __enter__(self) -> "CheckLogWriter":
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def _upgrade_layout(path: Path, log: "CheckLog") -> None:
    """Rewrite a log of an earlier layout (without the tool or the covariance columns) in the
    present one, atomically: the tag and comment lines as they are, the header of today, every
    row with an empty tool (when it had none) and empty covariance columns."""
    text = read_text(path, "a check log (checks.csv)")
    out, header_seen = [], False
    for line in text.splitlines():
        if not line.strip() or line.lstrip().startswith("#"):
            out.append(line)
        elif not header_seen:
            out.append(",".join(header_columns(log.dof)))
            header_seen = True
        else:
            out.append(line + ("," if not log.tool_column else "") + "," * len(COVARIANCE))
    atomic_write_text(path, "\n".join(out) + "\n")


def _number(path, line_no: int, column: str, text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not math.isfinite(value):
        raise RoboCalError(f"line {line_no}: expected a number, got {text!r}", source=path, field=column,
                           hint="Restore the log from a backup or start a new one.")
    return value


def read_check_log(path: str | Path) -> CheckLog:
    """Every check in a log, in the order they were run. Raises RoboCalError naming the file,
    line and column for a file that is not a check log or holds a bad value."""
    path = Path(path)
    text = read_text(path, "a check log (checks.csv)")
    lines = text.splitlines(keepends=True)
    if not lines or not lines[0].startswith("#") or FAMILY not in lines[0]:
        raise RoboCalError("not a RoboCal check log (its first line must be the format tag)", source=path,
                           field="line 1", hint=f"The first line of a check log is '{TAG}'.")
    tag = lines[0].split(";")[0].strip("# \n")
    if tag != FORMAT:
        raise RoboCalError(f"unsupported check log version '{tag}'", source=path, field="line 1",
                           hint="Use a check log written by this version of RoboCal.")
    complete = text if text.endswith("\n") else "".join(lines[:-1])   # a cut-off last row is dropped
    header: list[str] | None = None
    dof = 0
    tool_column = covariance_columns = True
    checks: dict[str, LoggedCheck] = {}
    for line_no, row in enumerate(csv.reader(io.StringIO(complete)), start=1):
        if not row or row[0].lstrip().startswith("#"):
            continue
        if header is None:
            header = row
            covariance_columns = row[-6:] == COVARIANCE
            tool_column = covariance_columns or row[-1:] == ["tool"]
            dof = len(row) - 14 - tool_column - 6 * covariance_columns
            if dof < 1 or row != header_columns(dof, tool_column, covariance_columns):
                raise RoboCalError(f"line {line_no}: expected the header {','.join(header_columns(6))} "
                                   f"(q1 … qn for n joints)", source=path, field="header")
            continue
        if len(row) != len(header):
            raise RoboCalError(f"line {line_no}: expected {len(header)} values, found {len(row)}",
                               source=path, field=f"line {line_no}")
        cols = dict(zip(header, row))
        run, kind = cols["run"].strip(), cols["kind"].strip()
        if not run:
            raise RoboCalError(f"line {line_no}: empty run name", source=path, field="run")
        tool = cols.get("tool", "").strip()
        check = checks.setdefault(run, LoggedCheck(run, cols["time"], tool=tool))
        within = cols["within"].strip()
        if within not in ("0", "1"):
            raise RoboCalError(f"line {line_no}: expected 1 or 0, got {within!r}", source=path, field="within")
        err = _number(path, line_no, "error_mm", cols["error_mm"])
        lim = _number(path, line_no, "limit_mm", cols["limit_mm"])
        if kind == OVERALL:
            check.rms_mm, check.rms_limit_mm, check.within = err, lim, within == "1"
        elif kind == POINT:
            try:
                pose = int(cols["pose"])
            except ValueError:
                raise RoboCalError(f"line {line_no}: expected a whole pose number, got {cols['pose']!r}",
                                   source=path, field="pose") from None
            num = {c: _number(path, line_no, c, cols[c])
                   for c in [f"q{i + 1}" for i in range(dof)] + ["x", "y", "z", "px", "py", "pz"]}
            check.points.append(LoggedPoint(
                pose, cols["target"], np.array([num[f"q{i + 1}"] for i in range(dof)]),
                np.array([num["x"], num["y"], num["z"]]), np.array([num["px"], num["py"], num["pz"]]),
                err, lim, within == "1", cols["time"], tool, _covariance(path, line_no, cols)))
        else:
            raise RoboCalError(f"line {line_no}: expected 'point' or 'overall', got {kind!r}", source=path,
                               field="kind")
    if header is None:
        raise RoboCalError("the check log has no header line", source=path, field="header",
                           hint="Start a new check log.")
    return CheckLog(list(checks.values()), dof, path, tool_column, covariance_columns)


def _covariance(path, line_no: int, cols: dict) -> np.ndarray | None:
    """A point row's own covariance (3, 3) mm², None when its covariance columns are empty or
    absent; RoboCalError for some filled and some empty, a bad number, or entries that give a
    negative variance in some direction."""
    texts = [cols.get(c, "").strip() for c in COVARIANCE]
    if not any(texts):
        return None
    if not all(texts):
        raise RoboCalError(f"line {line_no}: the covariance columns are partly empty", source=path,
                           field=COVARIANCE[texts.index("")], hint="Fill all six or leave all six empty.")
    C = np.zeros((3, 3))
    for (i, j), c, t in zip(_UPPER, COVARIANCE, texts):
        C[i, j] = C[j, i] = _number(path, line_no, c, t)
    if usable_covariance(C) is None:
        raise RoboCalError(f"line {line_no}: cxx … czz give a negative variance in some direction", source=path,
                           field="cxx", hint="Restore the log from a backup, or empty the six covariance columns.")
    return C
