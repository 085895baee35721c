"""The measurement run: drive the robot through a pose list, capture, locate, write as it goes.

`run_measurements(poses, out, locate=..., capture=..., driver=...)` takes each pose in turn:
moves the robot there (a `core.robot.driver.RobotDriver`; it refuses joint values outside the
limits, and such a pose is rejected with the driver's reason, the robot not moved), captures
a stereo pair (`capture(q) -> (left, right)`, e.g. `lambda q: lab.render_marker_pair(q, rng)`,
`capture_pose(pose_id, q)` for images on disk, or `source`, a core.measurement.capture
StereoSource / RenderedSource captured once the robot has settled), locates the marker
(`locate(left, right) -> MarkerLocation`, e.g. a `MarkerLocator`'s or `MarkerTracker`'s), and
appends the point at once to the measurements file (core.measurement.file.MeasurementWriter:
flushed and fsynced per row, so nothing taken is lost if the program dies) or the pose, with
the reason, to the rejects file (`<out>.rejects.csv`, format robocal.rejects/1, also
fsynced per row).

Resumable: the poses already in the measurements file (same target) or in the rejects file
are skipped (their joint values must match, else the file belongs to another pose list).
Faults: when the robot or its connection fails (core.robot.driver.RobotFault: timeout,
garbage, disconnect, a controller error, a robot that ended away from its target; a move
the driver's watchdog stopped, RobotTimeout, is a fault too, not a Stop) the run
stops the robot, keeps every measurement taken, and returns with `fault` (one line); the
pose under way is not written. Reconnect and run again with `resume`: it starts at the first
unmeasured pose. Nothing captured while the robot moved or after a stop is written.
Pause: while `paused()` is true the run waits between poses. Cancel: `cancelled()` stops the
run between poses and the result comes back with `cancelled` True (not an exception: all that
was measured is on disk, and the result says what).
"""
from __future__ import annotations

import csv
import io
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Sequence

import numpy as np

from core.errors import RoboCalError
from core.files import drop_partial_last_line, require_regular_file
from core.robot.driver import RobotFault, RobotTimeout
from core.robot.model import RobotModel
from core.measurement.appended_file import AppendedFile
from core.measurement.file import MeasurementWriter, orientation_cells
from core.poses.file import PoseList

REJECTS_FAMILY = "robocal.rejects"
REJECTS_FORMAT = f"{REJECTS_FAMILY}/1"
REJECTS_TAG = f"# {REJECTS_FORMAT} ; poses that gave no measurement, with the reason"
JOINT_TOLERANCE = 0.05         # file units (deg / mm): the same pose when resuming (a real robot
                               # records the joint values its encoders report, not the commanded ones)


def rejects_path_for(out: str | Path) -> Path:
    """`meas.csv` -> `meas.rejects.csv`."""
    out = Path(out)
    return out.with_name(out.stem + ".rejects" + (out.suffix or ".csv"))


# -- pose lists -------------------------------------------------------------------------------------

def poses_from_internal(Q, robot: RobotModel, ids=None) -> PoseList:
    """A core.poses.file.PoseList from joint values in internal units (rad / mm)."""
    Q = np.atleast_2d(np.asarray(Q, dtype=float))
    q_file = np.asarray(robot.q_to_file(Q), dtype=float).reshape(Q.shape)
    return PoseList(q_file=q_file, Q=Q, pose=np.arange(len(Q)) if ids is None else np.asarray(ids, int))


def _internal(poses: PoseList, driver) -> np.ndarray | None:
    """Joint values in internal units: the list's own, else converted with the driver's robot
    model; None for a list read without a robot and no robot to move (only the pose ids matter
    then, as for images captured beforehand)."""
    if poses.Q is not None:
        return np.asarray(poses.Q, dtype=float)
    if driver is not None:
        return np.asarray(driver.model.q_from_file(poses.q_file), dtype=float)
    return None


# -- rejects file -----------------------------------------------------------------------------------

def read_rejects(path: str | Path) -> dict[int, tuple[str, np.ndarray, str]]:
    """pose id -> (target, q_file, reason) of a rejects file (empty if it does not exist)."""
    path = require_regular_file(path)
    if not path.exists():
        return {}
    text = path.read_text(encoding="utf-8", errors="replace")
    out = {}
    header = None
    for line_no, row in enumerate(csv.reader(io.StringIO(text)), start=1):
        if not row or not "".join(row).strip() or row[0].lstrip().startswith("#"):
            if row and row[0].lstrip().startswith("#") and line_no == 1 and REJECTS_FAMILY not in ",".join(row):
                raise RoboCalError("not a RoboCal rejects file (no format tag)", source=path)
            continue
        if header is None:
            header = row
            if header[:2] != ["pose", "target"] or header[-1] != "reason":
                raise RoboCalError(f"line {line_no}: expected the header pose,target,q1..qn,reason", source=path)
            continue
        if len(row) != len(header):
            continue          # a partly written last line (interrupted): ignored, the pose is redone
        try:
            pose = int(row[0])
            q = np.array([float(v) for v in row[2:-1]])
        except ValueError:
            continue
        out[pose] = (row[1], q, row[-1])
    return out


@dataclass
class RejectsWriter(AppendedFile):
    """Appends rejected poses (pose, target, joints, reason), each row flushed and fsynced.

    Like core.measurement.file.MeasurementWriter: a failed write is one clear RoboCalError, and
    closing after it is quiet (the unwritten rest is dropped), so that first message is the one
    the user reads."""

    path: str | Path
    dof: int
    _handle: object = field(default=None, init=False, repr=False)
    _write_failed: bool = field(default=False, init=False, repr=False)

    def __post_init__(self):
        self.path = require_regular_file(self.path)
        header = ",".join(["pose", "target"] + [f"q{i + 1}" for i in range(self.dof)] + ["reason"])
        try:
            existing = self.path.read_bytes() if self.path.exists() else b""
        except OSError as exc:
            raise RoboCalError(f"cannot read the file ({exc.strerror})", source=self.path) from exc
        found = None
        if existing.strip():            # checked before anything is repaired or written: a refused file stays as it was
            complete = existing[:existing.rfind(b"\n") + 1] if not existing.endswith(b"\n") else existing
            lines = [ln for ln in existing.decode("utf-8", "replace").splitlines() if ln.strip()]
            found = next((ln for ln in complete.decode("utf-8", "replace").splitlines()
                          if ln.strip() and not ln.startswith("#")), None)
            if REJECTS_FAMILY not in lines[0] or (found is not None and found.replace(" ", "") != header):
                raise RoboCalError("the rejects file belongs to another run (other columns or no format tag)",
                                   source=self.path, hint="Write to a new file.")
            drop_partial_last_line(self.path)
        try:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            self._handle = open(self.path, "a", encoding="utf-8", newline="")
        except OSError as exc:
            raise RoboCalError(f"cannot open the file for writing ({exc.strerror})", source=self.path) from exc
        try:
            if not existing.strip():
                self._append(REJECTS_TAG + "\n" + header + "\n")
            elif found is None:
                self._append(header + "\n")
        except BaseException:
            self._write_failed = True           # the error on its way is the one to read
            self.close()
            raise

    def append(self, pose: int, target: str, q_file: Sequence[float], reason: str) -> None:
        """Write one rejected pose (joint values in file units: deg / mm) and flush it to disk."""
        buf = io.StringIO()
        csv.writer(buf, lineterminator="\n").writerow(
            [int(pose), target] + [f"{float(v):.6f}" for v in q_file] + [" ".join(str(reason).split())])
        if self._handle is None:
            raise RoboCalError("the rejects file is closed", source=self.path)
        self._append(buf.getvalue())



# -- existing measurements ----------------------------------------------------------------------------

def _existing_measurements(path: Path, target: str) -> tuple[dict[int, np.ndarray], set[str] | None]:
    """pose id -> q_file of the rows of `target` already in the file; and the file's column
    names (None when the file does not exist or has no header yet). A partly
    written last line (a run killed while writing) is not a measurement: it is ignored here
    and ended by the writer."""
    from core.measurement.file import read_measurements

    if not require_regular_file(path).exists() or not path.read_bytes().strip():
        return {}, None
    text = path.read_text(encoding="utf-8", errors="replace")
    complete = text if text.endswith("\n") else text[:text.rfind("\n") + 1]
    lines = [ln.strip() for ln in complete.splitlines() if ln.strip() and not ln.lstrip().startswith("#")]
    if not lines:
        return {}, None
    columns = set(lines[0].replace(" ", "").split(","))
    if len(lines) < 2:
        return {}, columns
    if complete is text:
        meas = read_measurements(path)
    else:
        with tempfile.TemporaryDirectory() as tmp:
            copy = Path(tmp) / path.name
            copy.write_text(complete, encoding="utf-8")
            try:
                meas = read_measurements(copy)
            except RoboCalError as exc:
                raise RoboCalError(exc.problem, source=path, hint=exc.hint) from None
    return {int(meas.pose[i]): meas.q_file[i] for i in range(meas.n_points) if meas.target[i] == target}, columns


# -- the run --------------------------------------------------------------------------------------

@dataclass
class PoseOutcome:
    """What happened at one pose (the GUI lists and draws these)."""

    index: int                     # position in the pose list
    pose: int                      # pose id
    q_file: np.ndarray             # joint values (deg / mm)
    status: str                    # "measured", "rejected" or "skipped" (done in an earlier run)
    reason: str = ""
    point: np.ndarray | None = None     # mm, left camera frame
    sigma: np.ndarray | None = None     # mm
    location: object | None = None      # the MarkerLocation (what to draw), when kept
    seconds: float = 0.0
    move_seconds: float = 0.0           # of `seconds`: the move until settled and read back
    capture_seconds: float = 0.0        # of `seconds`: the capture
    grab_gap: float | None = None       # s between the two cameras' grabs (a capture source)


@dataclass
class MeasurementRunResult:
    measurements_path: Path
    rejects_path: Path
    total: int
    outcomes: list[PoseOutcome] = field(default_factory=list)
    cancelled: bool = False
    fault: str | None = None       # why the run stopped early (robot or connection), one line

    @property
    def measured(self) -> list[PoseOutcome]:
        return [o for o in self.outcomes if o.status == "measured"]

    @property
    def rejected(self) -> list[PoseOutcome]:
        return [o for o in self.outcomes if o.status == "rejected"]

    @property
    def skipped(self) -> list[PoseOutcome]:
        return [o for o in self.outcomes if o.status == "skipped"]

    @property
    def remaining(self) -> int:
        """Poses not yet measured nor rejected (after a cancel)."""
        return self.total - len(self.outcomes)

    def summary(self) -> dict:
        return {
            "measurements": str(self.measurements_path), "rejects": str(self.rejects_path),
            "poses": self.total, "measured": len(self.measured), "rejected": len(self.rejected),
            "skipped": len(self.skipped), "remaining": self.remaining, "cancelled": self.cancelled,
            "fault": self.fault,
            "rejects_list": [{"pose": o.pose, "reason": o.reason} for o in self.rejected],
        }


def run_measurements(poses: PoseList, out: str | Path, *, locate: Callable, capture: Callable | None = None,
                     capture_pose: Callable | None = None, source=None, driver=None, target: str = "marker",
                     rejects: str | Path | None = None, resume: bool = True, retry_rejected: bool = False,
                     keep_locations: bool = True, on_pose: Callable[[PoseOutcome], None] | None = None,
                     progress=None, cancelled=None, paused=None, pause_poll: float = 0.05) -> MeasurementRunResult:
    """Measure every pose of `poses` (core.poses.file.PoseList, e.g. from `read_poses`) into
    `out` (measurements.csv) and its rejects file.

    `locate(left, right)` returns a MarkerLocation (ok, reason, point, covariance).
    `capture(q)` (internal units) or `capture_pose(pose_id, q)` returns the (left, right) pair;
    or `source.capture()` returns StereoFrames (core.measurement.capture).
    `driver`: a connected RobotDriver moved to each pose first (optional: without one, the
    images are taken as given). `resume`: skip the poses already in the files (else an
    existing non-empty measurements file is refused). `retry_rejected`: measure previously
    rejected poses again. `on_pose(outcome)` is called after each pose, once its row is on disk."""
    if sum(c is not None for c in (capture, capture_pose, source)) != 1:
        raise ValueError("give exactly one of capture, capture_pose and source")
    out = Path(out)
    rejects = Path(rejects) if rejects is not None else rejects_path_for(out)
    ids = np.asarray(poses.pose, dtype=int).reshape(-1)
    q_files = np.atleast_2d(np.asarray(poses.q_file, dtype=float))
    Q_all = _internal(poses, driver)
    dof = q_files.shape[1]
    if len(set(ids.tolist())) != len(ids):
        raise RoboCalError("the pose list has a pose number twice", source=getattr(poses, "path", None),
                           hint="Give every pose its own number.")
    done_meas, columns = _existing_measurements(out, target)
    if done_meas and not resume:
        raise RoboCalError(f"the file already holds {len(done_meas)} measurements", source=out,
                           hint="Resume the run, or choose a new file.")
    done_rej = read_rejects(rejects) if resume else {}
    if not resume and rejects.exists() and rejects.read_bytes().strip():
        raise RoboCalError("the rejects file of an earlier run exists", source=rejects,
                           hint="Resume the run, or choose a new file.")
    by_id = {int(p): i for i, p in enumerate(ids)}
    for pid, q in done_meas.items():
        i = by_id.get(pid)
        if i is not None and (len(q) != dof or np.max(np.abs(q - q_files[i])) > JOINT_TOLERANCE):
            raise RoboCalError(f"pose {pid} in the file has other joint values than in the pose list", source=out,
                               hint="This file belongs to another pose list: write to a new file.")
    # a new file has sigmas and orientation columns; an existing one keeps its own
    writer = MeasurementWriter(out, dof, sigmas=columns is None or "sx" in columns,
                               orientation=columns is None or "rx" in columns)
    rej_writer = None
    result = MeasurementRunResult(out, rejects, len(poses))
    total = max(len(poses), 1)

    def report(i: int, msg: str) -> None:
        if progress is not None:
            progress(i / total, msg)

    def is_cancelled() -> bool:
        return bool(cancelled is not None and cancelled())

    try:
        for i, pid in enumerate(ids):
            pid = int(pid)
            q, q_file = (Q_all[i] if Q_all is not None else None), q_files[i]
            if pid in done_meas:
                result.outcomes.append(PoseOutcome(i, pid, q_file, "skipped", "measured in an earlier run"))
                continue
            if pid in done_rej and not retry_rejected:
                result.outcomes.append(PoseOutcome(i, pid, q_file, "skipped",
                                                   f"rejected in an earlier run: {done_rej[pid][2]}"))
                continue
            while paused is not None and paused() and not is_cancelled():
                report(i, "paused")
                time.sleep(pause_poll)
            if is_cancelled():
                result.cancelled = True
                break
            report(i, f"pose {pid} ({i + 1}/{len(poses)})")
            t0 = time.perf_counter()
            outcome = PoseOutcome(i, pid, q_file, "rejected")
            reason = ""
            location = None
            try:
                if driver is not None:
                    try:
                        driver.check_joints(q)
                    except RoboCalError as exc:
                        raise _PoseRejected(exc.problem) from None
                    driver.move_to(q)          # a robot that is stopped or disconnected aborts the run
                    q_now = driver.current_joints()
                    q_record = driver.model.q_to_file(q_now)   # what the robot reports it reached
                else:
                    q_now, q_record = q, q_file
                t_moved = time.perf_counter()
                outcome.move_seconds = t_moved - t0
                try:
                    if source is not None:
                        frames = source.capture()
                        pair, outcome.grab_gap = (frames.left, frames.right), frames.grab_gap_s
                    else:
                        pair = capture(q_now) if capture is not None else capture_pose(pid, q_now)
                except RobotFault:
                    raise
                except RoboCalError as exc:
                    raise _PoseRejected(f"capture failed: {exc.message}") from None
                outcome.capture_seconds = time.perf_counter() - t_moved
                if pair is None or len(pair) != 2 or pair[0] is None or pair[1] is None:
                    raise _PoseRejected("capture failed: no image pair")
                if driver is not None and driver.stopped:
                    raise RoboCalError("the robot was stopped while this pose was captured; it is not recorded",
                                       source=driver.name, hint="Resume the robot, then resume the run.")
                location = locate(pair[0], pair[1])
                if not location.ok:
                    raise _PoseRejected(location.reason)
                point = np.asarray(location.point, dtype=float)
                sig = (np.maximum(np.asarray(location.sigma, dtype=float), 1e-6)      # written with 6 decimals
                       if location.covariance is not None else None)
                orientation = getattr(location, "orientation", None)
                writer.append(pid, target, q_record, point, sig if writer.sigmas else None,
                              orientation_cells(orientation.rotation_vector, np.sqrt(np.diag(orientation.covariance)))
                              if orientation is not None and writer.orientation else None)
                outcome.status, outcome.point, outcome.sigma = "measured", point, sig
            except _PoseRejected as rej:
                reason = str(rej)
                if rej_writer is None:
                    rej_writer = RejectsWriter(rejects, dof)
                rej_writer.append(pid, target, q_file, reason)
                outcome.reason = reason
            except RobotFault as exc:
                # stopped on purpose during the move; the watchdog's stop is a fault the user must read
                stop_key = driver is not None and driver.stopped and not isinstance(exc, RobotTimeout)
                if driver is not None:
                    driver.stop()              # never raises; the robot stays stopped until resumed
                if stop_key:
                    result.cancelled = True    # the Stop key ends the run like a cancel, not as a fault
                else:
                    result.fault = exc.message
                break
            outcome.location = location if keep_locations else None
            outcome.seconds = time.perf_counter() - t0
            result.outcomes.append(outcome)
            if on_pose is not None:
                on_pose(outcome)
        else:
            report(len(poses), "done")
        if result.fault:
            report(len(result.outcomes), result.fault)
    except BaseException:
        _close(writer, rej_writer, quiet=True)      # the error on its way is the one the user reads
        raise
    _close(writer, rej_writer)
    return result


def _close(*writers, quiet: bool = False) -> None:
    """Close every writer; then raise the first close error unless `quiet`."""
    first = None
    for w in writers:
        if w is not None:
            try:
                w.close()
            except RoboCalError as exc:
                first = first or exc
    if first is not None and not quiet:
        raise first


class _PoseRejected(Exception):
    """Internal: this pose gives no measurement (the message is the reason)."""

