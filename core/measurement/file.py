"""The measurements file `measurements.csv` (format robocal.measurements/1, DESIGN.md).

```
# robocal.measurements/1 ; lines starting with # are comments
pose,target,q1,q2,q3,q4,q5,q6,x,y,z
0,marker,10.0,-35.2,20.1,0.0,45.0,0.0,412.31,-20.55,815.02
```

One row per measured point: the pose id (an integer), the target name (a point of the robot
model's `targets`), the joint values in file units (degrees for revolute, mm for prismatic
joints), and the point's position x, y, z in mm in the measurement (left camera) frame.
Optional columns `sx,sy,sz` give each coordinate's standard deviation in mm. Optional columns
`rx,ry,rz,srx,sry,srz` (all six together, after the sigmas) give the measured orientation of the
marker frame: its rotation vector in the measurement frame and the standard deviations of the small
rotations about the measurement frame's x, y, z axes, all in degrees; the six cells of a row may be
empty (no orientation for that point). A file with them is tagged version 1.1. Several targets
may be measured in one pose (one row each, with the same joint values); a target may appear
in only some poses.

The format tag must be in the first comment line. Readers accept any minor version of major
version 1; columns unknown to this reader are refused in version 1.0 (a typo such as `s_x`
would otherwise silently drop the sigmas) and ignored in later minor versions.

`MeasurementWriter` appends one row at a time and flushes it to disk (fsync) at once, so a
measurement run that is interrupted keeps every point taken so far.
"""
from __future__ import annotations

import csv
import io
import math
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Iterable, Sequence

import numpy as np

from core.bounds import ANGLE_DEG, LENGTH_MM, POINT_COUNT, POSE_ID, SIGMA_MM, Bound
from core.errors import RoboCalError
from core.files import atomic_write_text, drop_partial_last_line, read_text, require_regular_file
from core.measurement.appended_file import AppendedFile
from core.robot.model import RobotModel

FORMAT_FAMILY = "robocal.measurements"
FORMAT_MAJOR = 1
FORMAT = f"{FORMAT_FAMILY}/{FORMAT_MAJOR}"
TAG_LINE = f"# {FORMAT} ; lines starting with # are comments"
SIGMA_COLUMNS = ("sx", "sy", "sz")
ORIENTATION_COLUMNS = ("rx", "ry", "rz", "srx", "sry", "srz")     # deg: rotation vector, its sigmas
ROTATION_DEG = Bound(-180.0, 180.0, "degrees", "a rotation vector turns at most 180°")
ROTATION_SIGMA_DEG = Bound(1e-9, 180.0, "degrees", "an orientation known to worse than 180° is no measurement")
ORIENTATION_MINOR = 1      # a file with orientation columns is tagged robocal.measurements/1.1
XYZ_COLUMNS = ("x", "y", "z")
_TAG_RE = re.compile(re.escape(FORMAT_FAMILY) + r"/(\S*)")
# Digits written for joint values and coordinates: 1e-6 mm / 1e-6 deg, far below any noise.
DECIMALS = 6


def header_columns(dof: int, sigmas: bool = False, orientation: bool = False) -> list[str]:
    """The column names of a measurements file for a robot with `dof` joints."""
    cols = ["pose", "target"] + [f"q{i + 1}" for i in range(dof)] + list(XYZ_COLUMNS)
    cols = cols + list(SIGMA_COLUMNS) if sigmas else cols
    return cols + list(ORIENTATION_COLUMNS) if orientation else cols


def tag_line(orientation: bool = False) -> str:
    """The format tag line: version 1.1 when the file carries orientation columns."""
    return TAG_LINE.replace(FORMAT, f"{FORMAT}.{ORIENTATION_MINOR}") if orientation else TAG_LINE


@dataclass
class Measurements:
    """Measured points, one entry per file row (N rows).

    pose:    (N,) int pose id of each point
    target:  N target names
    q_file:  (N, n) joint values in file units (deg for revolute, mm for prismatic)
    Q:       (N, n) joint values in internal units (rad / mm); None when read without a robot
    xyz:     (N, 3) measured positions, mm, measurement frame
    sigma:   (N, 3) standard deviations in mm, or None when the file has no sx,sy,sz columns
    rotation: (N, 3) measured rotation vectors of the marker frame (rad, measurement frame), NaN
             rows where a point has none; None when the file has no orientation columns
    rotation_sigma: (N, 3) standard deviations (rad) of the small rotations about the measurement
             frame's x, y, z; NaN / None as `rotation`
    line:    (N,) line number of each point in the file (1-based; 0 when not from a file)
    source:  the file the points came from
    """

    pose: np.ndarray
    target: list[str]
    q_file: np.ndarray
    xyz: np.ndarray
    Q: np.ndarray | None = None
    sigma: np.ndarray | None = None
    line: np.ndarray | None = None
    source: str = ""
    minor_version: int = 0
    rotation: np.ndarray | None = None
    rotation_sigma: np.ndarray | None = None

    def __post_init__(self):
        self.pose = np.asarray(self.pose, dtype=int).reshape(-1)
        self.target = [str(t) for t in self.target]
        self.q_file = np.atleast_2d(np.asarray(self.q_file, dtype=float))
        self.xyz = np.asarray(self.xyz, dtype=float).reshape(-1, 3)
        if self.Q is not None:
            self.Q = np.atleast_2d(np.asarray(self.Q, dtype=float))
        if self.sigma is not None:
            self.sigma = np.asarray(self.sigma, dtype=float).reshape(-1, 3)
        if (self.rotation is None) != (self.rotation_sigma is None):
            raise ValueError("rotation and rotation_sigma go together")
        if self.rotation is not None:
            self.rotation = np.asarray(self.rotation, dtype=float).reshape(-1, 3)
            self.rotation_sigma = np.asarray(self.rotation_sigma, dtype=float).reshape(-1, 3)
        if self.line is None:
            self.line = np.zeros(len(self.pose), dtype=int)
        n = len(self.pose)
        if len(self.target) != n or len(self.q_file) != n or len(self.xyz) != n:
            raise ValueError("pose, target, q_file and xyz must have the same length")

    # -- views ---------------------------------------------------------------------------
    @property
    def n_points(self) -> int:
        return len(self.pose)

    @property
    def dof(self) -> int:
        return self.q_file.shape[1]

    @property
    def pose_ids(self) -> np.ndarray:
        """The distinct pose ids, in order of first appearance."""
        _, first = np.unique(self.pose, return_index=True)
        return self.pose[np.sort(first)]

    @property
    def n_poses(self) -> int:
        return len(np.unique(self.pose))

    @property
    def target_names(self) -> list[str]:
        """The distinct target names, in order of first appearance."""
        return list(dict.fromkeys(self.target))

    @property
    def has_orientation(self) -> np.ndarray:
        """(N,) True where a point carries a measured orientation."""
        if self.rotation is None:
            return np.zeros(self.n_points, bool)
        return np.all(np.isfinite(self.rotation), axis=1) & np.all(np.isfinite(self.rotation_sigma), axis=1)

    def subset(self, mask) -> "Measurements":
        """The points where `mask` (boolean or index array) selects."""
        idx = np.arange(self.n_points)[mask]
        return Measurements(
            pose=self.pose[idx], target=[self.target[i] for i in idx], q_file=self.q_file[idx],
            xyz=self.xyz[idx], Q=None if self.Q is None else self.Q[idx],
            sigma=None if self.sigma is None else self.sigma[idx], line=self.line[idx],
            source=self.source, minor_version=self.minor_version,
            rotation=None if self.rotation is None else self.rotation[idx],
            rotation_sigma=None if self.rotation_sigma is None else self.rotation_sigma[idx])

    def select_poses(self, pose_ids: Iterable[int]) -> "Measurements":
        """All points of the given poses."""
        return self.subset(np.isin(self.pose, np.asarray(list(pose_ids), dtype=int)))

    def with_robot(self, robot: RobotModel) -> "Measurements":
        """A copy with Q converted to internal units through `robot` (checks the joint count)."""
        check_against_robot(self, robot, targets=False)
        out = self.subset(slice(None))
        out.Q = robot.q_from_file(self.q_file)
        return out

    def where(self, i: int) -> str:
        """'line 12' for point i (or 'point 12' when not from a file)."""
        return f"line {self.line[i]}" if self.line[i] else f"point {i}"


# -- reading -------------------------------------------------------------------------------
def _error(path, line_no: int, problem: str, hint: str | None = None, column: str | None = None):
    where = f"line {line_no}"
    if column is not None:
        where += f", column '{column}'"
    return RoboCalError(f"{where}: {problem}", source=path, hint=hint)


def _parse_tag(path, line_no: int, line: str) -> int:
    """Check the format tag of the first comment line; return the minor version."""
    match = _TAG_RE.search(line)
    if match is None:
        raise _error(path, line_no, f"the first comment line must carry the format tag '{FORMAT}'",
                     hint=f"Start the file with the line '{TAG_LINE}'.")
    version = match.group(1).rstrip(";,")
    major, _, minor = version.partition(".")
    if not major.isdigit() or (minor and not minor.isdigit()):
        raise _error(path, line_no, f"bad format version '{version}'", hint=f"Use '{FORMAT}'.")
    if int(major) != FORMAT_MAJOR:
        raise _error(path, line_no,
                     f"unknown format version {major} (this RoboCal reads version {FORMAT_MAJOR})",
                     hint="Use a RoboCal release that reads this version, or re-export the file.")
    return int(minor or 0)


def _number(path, line_no: int, column: str, text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        shown = f"the text '{text}'" if text.strip() else "an empty cell"
        raise _error(path, line_no, f"expected a number, got {shown}", column=column,
                     hint="Write a plain number (a dot as decimal separator, no units).") from None
    if not math.isfinite(value):
        raise _error(path, line_no, f"expected a finite number, got '{text}'", column=column,
                     hint="Remove the row or measure this point again.")
    return value


def _bounded(path, line_no: int, column: str, text: str, bound: Bound) -> float:
    """A number within its plausibility bound (core.bounds)."""
    value = _number(path, line_no, column, text)
    if not bound.lo <= value <= bound.hi:
        raise _error(path, line_no, f"{value:g} {bound.unit} is outside {bound.lo:g} … {bound.hi:g} {bound.unit} "
                     f"({bound.reason})", column=column, hint="Check the value and its unit.")
    return value


def _check_header(path, line_no: int, cols: list[str], minor: int, dof: int | None) -> dict:
    """Validate the header; return the column layout {name: index}, joint count, sigmas flag."""
    seen = {}
    for i, c in enumerate(cols):
        if c in seen:
            raise _error(path, line_no, f"the column '{c}' appears twice")
        seen[c] = i
    for c in ("pose", "target") + XYZ_COLUMNS:
        if c not in seen:
            raise _error(path, line_no, f"missing column '{c}'",
                         hint="The header must be pose,target,q1..qn,x,y,z[,sx,sy,sz].")
    q_cols = [c for c in cols if re.fullmatch(r"q\d+", c)]
    n_q = len(q_cols)
    if n_q == 0:
        raise _error(path, line_no, "no joint columns (q1, q2, ...)",
                     hint="The header must be pose,target,q1..qn,x,y,z[,sx,sy,sz].")
    expected = [f"q{i + 1}" for i in range(n_q)]
    if sorted(q_cols, key=lambda c: int(c[1:])) != expected:
        missing = sorted(set(expected) - set(q_cols), key=lambda c: int(c[1:]))
        raise _error(path, line_no, f"the joint columns must be q1..q{n_q}; missing {', '.join(missing)}")
    if dof is not None and n_q != dof:
        raise _error(path, line_no, f"the file has {n_q} joint columns (q1..q{n_q}) but the robot has "
                     f"{dof} joints", hint="Use the robot model these measurements were taken with.")
    has_sigma = [c in seen for c in SIGMA_COLUMNS]
    if any(has_sigma) and not all(has_sigma):
        missing = [c for c, h in zip(SIGMA_COLUMNS, has_sigma) if not h]
        raise _error(path, line_no, f"missing column '{missing[0]}' (sx, sy, sz go together)")
    has_rot = [c in seen for c in ORIENTATION_COLUMNS]
    if any(has_rot) and not all(has_rot):
        missing = [c for c, h in zip(ORIENTATION_COLUMNS, has_rot) if not h]
        raise _error(path, line_no, f"missing column '{missing[0]}' (rx, ry, rz, srx, sry, srz go together)")
    known = {"pose", "target", *XYZ_COLUMNS, *SIGMA_COLUMNS, *ORIENTATION_COLUMNS, *expected}
    unknown = [c for c in cols if c not in known]
    if unknown and minor == 0:
        raise _error(path, line_no, f"unknown column '{unknown[0]}'",
                     hint="Allowed columns: pose, target, q1..qn, x, y, z, sx, sy, sz, rx, ry, rz, srx, sry, srz.")
    return {"index": seen, "n_q": n_q, "sigmas": all(has_sigma), "orientation": all(has_rot)}


def read_measurements(path: str | Path, robot: RobotModel | None = None) -> Measurements:
    """Read and validate a measurements file.

    With a `robot`, the joint count is checked against it, Q is converted to internal units
    and every target must be one of the robot's targets. Every error names the file, the line
    and the column, and says what to do.
    """
    path = Path(path)
    text = read_text(path, "a measurements CSV file")

    minor = None
    layout = None
    rows: list[tuple[int, list[str]]] = []
    for line_no, raw in enumerate(io.StringIO(text), start=1):
        line = raw.strip()
        if not line:
            continue
        if line.startswith("#"):
            if minor is None:
                minor = _parse_tag(path, line_no, line)
            continue
        if minor is None:
            raise _error(path, line_no, f"the file must start with the format tag line '{TAG_LINE}'",
                         hint="Is this a RoboCal measurements file? Add the tag line if it is.")
        try:
            cells = [c.strip() for c in next(csv.reader([line]))]
        except csv.Error as exc:              # e.g. a field over the csv module's 128 KiB limit
            raise _error(path, line_no, f"unreadable row ({exc})", hint="Check the row; is this a CSV file?") from None
        if layout is None:
            layout = _check_header(path, line_no, cells, minor, robot.dof if robot is not None else None)
            header_len = len(cells)
            continue
        if len(cells) != header_len:
            raise _error(path, line_no, f"expected {header_len} values (as in the header), got {len(cells)}",
                         hint="Check for a missing or extra comma.")
        rows.append((line_no, cells))
        if len(rows) > POINT_COUNT.hi:
            raise _error(path, line_no, f"more than {POINT_COUNT.hi:,.0f} measured points ({POINT_COUNT.reason})",
                         hint="Split the file, or keep a subset of the poses.")
    if minor is None:
        raise RoboCalError("empty file (no format tag, no header)", source=path,
                           hint=f"A measurements file starts with '{TAG_LINE}'.")
    if layout is None:
        raise RoboCalError("no header line", source=path,
                           hint="After the tag line comes pose,target,q1..qn,x,y,z.")
    if not rows:
        raise RoboCalError("no measurements (the file has a header but no rows)", source=path,
                           hint="Run the measurement step first.")

    idx, n_q = layout["index"], layout["n_q"]
    q_names = [f"q{i + 1}" for i in range(n_q)]
    # joint values in file units: degrees for revolute joints, mm for prismatic (the wider bound without a robot)
    q_bounds = ([ANGLE_DEG if j.revolute else LENGTH_MM for j in robot.joints] if robot is not None
                else [LENGTH_MM] * n_q)
    N = len(rows)
    pose = np.empty(N, dtype=int)
    targets: list[str] = []
    q_file = np.empty((N, n_q))
    xyz = np.empty((N, 3))
    sigma = np.empty((N, 3)) if layout["sigmas"] else None
    rotation = np.full((N, 6), np.nan) if layout["orientation"] else None
    lines = np.empty(N, dtype=int)
    seen_points: dict[tuple[int, str], int] = {}
    pose_q: dict[int, tuple[int, np.ndarray]] = {}
    for k, (line_no, cells) in enumerate(rows):
        lines[k] = line_no
        p_text = cells[idx["pose"]]
        try:
            pose_id = int(p_text)
        except ValueError:
            raise _error(path, line_no, f"expected a whole number as pose id, got '{p_text}'",
                         column="pose") from None
        if not POSE_ID.lo <= pose_id <= POSE_ID.hi:
            raise _error(path, line_no, f"pose id {p_text[:20]} is outside {POSE_ID.lo:g} … {POSE_ID.hi:g} "
                         f"({POSE_ID.reason})", column="pose")
        pose[k] = pose_id
        target = cells[idx["target"]]
        if not target:
            raise _error(path, line_no, "empty target name", column="target",
                         hint="Name the measured point (e.g. marker).")
        targets.append(target)
        for j, c in enumerate(q_names):
            q_file[k, j] = _bounded(path, line_no, c, cells[idx[c]], q_bounds[j])
        for j, c in enumerate(XYZ_COLUMNS):
            xyz[k, j] = _bounded(path, line_no, c, cells[idx[c]], LENGTH_MM)
        if sigma is not None:
            for j, c in enumerate(SIGMA_COLUMNS):
                s = _number(path, line_no, c, cells[idx[c]])
                if s <= 0:
                    raise _error(path, line_no, f"a standard deviation must be positive, got {s}", column=c)
                s = _bounded(path, line_no, c, cells[idx[c]], SIGMA_MM)
                sigma[k, j] = s
        if rotation is not None:
            rotation[k] = _orientation_cells(path, line_no, [cells[idx[c]] for c in ORIENTATION_COLUMNS])
        key = (int(pose[k]), target)
        if key in seen_points:
            raise _error(path, line_no, f"pose {pose[k]} target '{target}' was already measured "
                         f"on line {seen_points[key]}", hint="Remove the duplicate row.")
        seen_points[key] = line_no
        first = pose_q.setdefault(int(pose[k]), (line_no, q_file[k].copy()))
        if np.max(np.abs(first[1] - q_file[k])) > 1e-6:
            raise _error(path, line_no, f"pose {pose[k]} has other joint values than on line {first[0]}",
                         hint="Every row of one pose must carry the same joint values; give the pose a new id.")
    meas = Measurements(pose=pose, target=targets, q_file=q_file, xyz=xyz, sigma=sigma, line=lines,
                        source=str(path), minor_version=minor,
                        rotation=None if rotation is None else np.deg2rad(rotation[:, :3]),
                        rotation_sigma=None if rotation is None else np.deg2rad(rotation[:, 3:]))
    if robot is not None:
        meas = meas.with_robot(robot)
    return meas


def _orientation_cells(path, line_no: int, cells: list[str]) -> np.ndarray:
    """rx, ry, rz, srx, sry, srz (deg) of one row; all NaN when the six cells are empty."""
    if not any(c.strip() for c in cells):
        return np.full(6, np.nan)
    out = np.empty(6)
    for j, (c, text) in enumerate(zip(ORIENTATION_COLUMNS, cells)):
        if not text.strip():
            raise _error(path, line_no, "an orientation cell is empty while others are not", column=c,
                         hint="Give all six of rx, ry, rz, srx, sry, srz, or leave all six empty.")
        if j < 3:
            out[j] = _bounded(path, line_no, c, text, ROTATION_DEG)
        else:
            s = _number(path, line_no, c, text)
            if s <= 0:
                raise _error(path, line_no, f"a standard deviation must be positive, got {s}", column=c)
            out[j] = _bounded(path, line_no, c, text, ROTATION_SIGMA_DEG)
    return out


def check_against_robot(meas: Measurements, robot: RobotModel, *, targets: bool = True) -> None:
    """Joint count (and, with `targets`, target names) must match the robot (errors name file and line).
    Reading checks the joints only: identification estimates targets the robot file lacks."""
    src = meas.source or "<measurements>"
    if meas.dof != robot.dof:
        raise RoboCalError(f"the measurements have {meas.dof} joint values per row but the robot "
                           f"'{robot.name}' has {robot.dof} joints", source=src,
                           hint="Use the robot model these measurements were taken with.")
    for i, t in enumerate(meas.target if targets else ()):
        if t not in robot.targets:
            known = ", ".join(robot.targets) or "none"
            raise RoboCalError(f"{meas.where(i)}: target '{t}' is not defined in the robot "
                               f"'{robot.name}' (its targets: {known})", source=src,
                               hint="Add the target to the robot model's 'targets' or fix the name.")


# -- writing -------------------------------------------------------------------------------
def _fmt(value: float) -> str:
    return f"{float(value):.{DECIMALS}f}"


def format_row(pose: int, target: str, q_file: Sequence[float], xyz: Sequence[float],
               sigma: Sequence[float] | None = None, orientation: Sequence[float] | None = None) -> str:
    """One CSV row (without newline); values must be finite. `orientation`: the six values
    rx, ry, rz, srx, sry, srz in degrees (six empty cells when they are not all finite)."""
    if "," in target or "\n" in target or not target.strip():
        raise RoboCalError(f"invalid target name {target!r}", hint="Use a name without commas.")
    values = list(q_file) + list(xyz) + (list(sigma) if sigma is not None else [])
    if not all(math.isfinite(float(v)) for v in values):
        raise RoboCalError(f"pose {pose} target '{target}': a value is not a finite number",
                           hint="Measure this point again.")
    cells = [str(int(pose)), target.strip()] + [_fmt(v) for v in values]
    if orientation is not None:
        o = np.asarray(orientation, dtype=float).reshape(6)
        cells += [_fmt(v) for v in o] if np.all(np.isfinite(o)) and np.all(o[3:] > 0) else [""] * 6
    return ",".join(cells)


def orientation_cells(rotation, rotation_sigma) -> np.ndarray:
    """The six orientation values of one point in file units (deg) from internal ones (rad);
    sigmas at least 1e-6 deg (written with 6 decimals)."""
    sigma = np.maximum(np.rad2deg(np.asarray(rotation_sigma, float).reshape(3)), 1e-6)
    return np.concatenate([np.rad2deg(np.asarray(rotation, float).reshape(3)), sigma])


def format_measurements(meas: Measurements) -> str:
    """The whole file as text."""
    has_sigma = meas.sigma is not None
    has_rot = meas.rotation is not None
    lines = [tag_line(has_rot), ",".join(header_columns(meas.dof, has_sigma, has_rot))]
    for i in range(meas.n_points):
        lines.append(format_row(meas.pose[i], meas.target[i], meas.q_file[i], meas.xyz[i],
                                meas.sigma[i] if has_sigma else None,
                                orientation_cells(meas.rotation[i], meas.rotation_sigma[i]) if has_rot else None))
    return "\n".join(lines) + "\n"


def write_measurements(meas: Measurements, path: str | Path) -> Path:
    """Write a whole measurements file atomically (a failure leaves any previous file intact)."""
    return atomic_write_text(path, format_measurements(meas))


@dataclass
class MeasurementWriter(AppendedFile):
    """Appends measured points to a measurements file as they are taken.

    The file is opened in append mode; each `append` writes one line, flushes it and fsyncs,
    so every point taken survives a crash or a power cut. A new (or empty) file gets the tag
    line and the header first; an existing file must have the same header.

        with MeasurementWriter("meas.csv", dof=6) as w:
            w.append(0, "marker", q_deg, xyz_mm)
    """

    path: str | Path
    dof: int
    sigmas: bool = False
    orientation: bool = False          # rx, ry, rz, srx, sry, srz columns (deg)
    _handle: object = field(default=None, init=False, repr=False)
    _write_failed: bool = field(default=False, init=False, repr=False)

    def __post_init__(self):
        self.path = require_regular_file(self.path)
        header = ",".join(header_columns(self.dof, self.sigmas, self.orientation))
        existing = self._existing_header()
        if existing is not None and existing[0] is not None and existing[0] != header:
            raise RoboCalError(f"the file's columns ({existing[0]}) differ from the ones to write "
                               f"({header})", source=self.path,
                               hint="Write to a new file, or use the robot the file was started with.")
        if existing is not None and existing[0] is not None and not existing[1]:
            # an interrupted write left a partial row: it is no measurement, cut it off
            drop_partial_last_line(self.path)
        try:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            self._handle = open(self.path, "a", encoding="utf-8", newline="")
            if existing is None:
                self._write(tag_line(self.orientation) + "\n" + header + "\n")
            elif existing[0] is None:   # a tag line but no header yet
                self._write(("" if existing[1] else "\n") + header + "\n")
        except OSError as exc:
            raise RoboCalError(f"cannot open the file for writing ({exc.strerror})", source=self.path,
                               hint="Check the disk space and permissions.") from exc

    def _existing_header(self):
        """None for a missing/empty file, else (header line or None, ends with newline)."""
        try:
            data = self.path.read_bytes()
        except FileNotFoundError:
            return None
        except OSError as exc:
            raise RoboCalError(f"cannot read the file ({exc.strerror})", source=self.path) from exc
        if not data.strip():
            return None
        text = data.decode("utf-8", errors="replace")
        lines = [ln.strip() for ln in text.splitlines() if ln.strip()]
        if not lines[0].startswith("#") or _TAG_RE.search(lines[0]) is None:
            raise RoboCalError("not a RoboCal measurements file (no format tag)", source=self.path,
                               hint="Choose a new file name.")
        _parse_tag(self.path, 1, lines[0])
        header = next((ln for ln in lines[1:] if not ln.startswith("#")), None)
        if header is not None:
            header = header.replace(" ", "")
        return header, data.endswith(b"\n")

    def append(self, pose: int, target: str, q_file: Sequence[float], xyz: Sequence[float],
               sigma: Sequence[float] | None = None, orientation: Sequence[float] | None = None) -> None:
        """Write one measured point (joint values in file units: deg / mm) and flush it to disk.
        `orientation`: rx, ry, rz, srx, sry, srz (deg) for a file with orientation columns (None:
        empty cells, this point has none)."""
        if self._handle is None:
            raise RoboCalError("the measurements file is closed", source=self.path)
        if len(q_file) != self.dof:
            raise RoboCalError(f"{len(q_file)} joint values given, the file has {self.dof}", source=self.path)
        if (sigma is not None) != self.sigmas:
            raise RoboCalError("sigmas given for a file without sx,sy,sz columns" if sigma is not None
                               else "this file needs sx, sy, sz for every point", source=self.path)
        if orientation is not None and not self.orientation:
            raise RoboCalError("an orientation given for a file without rx, ry, rz columns", source=self.path)
        self._append(format_row(pose, target, q_file, xyz, sigma,
                                (orientation if orientation is not None else [np.nan] * 6) if self.orientation
                                else None) + "\n")
