"""The Measurement step's work, without Qt: which pose list to measure, the run in the virtual
lab, the status of each pose of a list read back from the files, moving old files aside, the
nominal model's predictions.

Files: the project's measurements.csv (core.measurement.file) and its rejects file
(core.measurement.run.rejects_path_for); points in mm in the left camera frame.
"""
from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from core.errors import RoboCalError
from core.measurement.file import read_measurements
from core.measurement.run import (JOINT_TOLERANCE, MeasurementRunResult, PoseOutcome, read_rejects,
                                  rejects_path_for, run_measurements)
from core.poses.candidates import arm_polyline
from core.poses.file import PoseList, read_pose_list
from core.poses.selection import minimum_poses
from core.thumbnails import marker_pair_thumbnail

THUMB_WIDTH = 400            # px per camera in the live thumbnail
MEASURED, REJECTED, PENDING, RUNNING = "measured", "rejected", "pending", "running"


@dataclass
class PoseRow:
    """One pose of the list as the page shows it: `point` and `sigma` in mm (left camera frame)."""

    index: int
    pose: int
    status: str = PENDING
    reason: str = ""
    point: np.ndarray | None = None
    sigma: np.ndarray | None = None


def measure_virtual(poses: PoseList, out: Path, trained, rect, driver, lab, seed: int, *, paused=None,
                    report=None, progress=None, cancelled=None) -> MeasurementRunResult:
    """The measurement run in the virtual lab: the driver moves, the lab renders the pair at
    the robot's joint values (generator seeded per pose), the locator finds the marker.
    `report(outcome, thumbnail)` after each pose (worker thread). A robot stopped by the
    user ends the run before the next pose, like a cancel."""
    from core.marker.location import MarkerLocator

    locator = MarkerLocator(trained, rect)
    last: dict = {}

    def capture_pose(pid, q):
        pair = lab.render_marker_pair(q, np.random.default_rng([int(seed), 41, int(pid)]))
        last["pair"] = pair
        last["loc"] = None
        return pair

    def locate(left, right):
        loc = locator.locate(left, right)
        last["loc"] = loc
        return loc

    def on_pose(outcome: PoseOutcome):
        if report is None:
            return
        pair, loc = last.get("pair"), last.get("loc")
        thumb = pair_thumbnail(pair, loc, outcome.status == MEASURED) if pair is not None else None
        last.clear()
        report(outcome, thumb)

    def stop_requested() -> bool:
        return bool((cancelled is not None and cancelled()) or (driver is not None and driver.stopped))

    return run_measurements(poses, out, locate=locate, capture_pose=capture_pose, driver=driver, resume=True,
                            keep_locations=False, on_pose=on_pose, progress=progress, cancelled=stop_requested,
                            paused=paused)


def pair_thumbnail(pair, loc, ok: bool) -> np.ndarray:
    """Left | right of `pair` reduced to THUMB_WIDTH px each, with what the locator `loc`
    (a MarkerLocation or None) found on each side."""
    dl = loc.left if loc is not None else None
    dr = loc.right if loc is not None else None
    return marker_pair_thumbnail(
        pair[0], pair[1], dl.outline.corners if dl is not None and dl.ok else None,
        dr.outline.corners if dr is not None and dr.ok else None,
        dl.reference if dl is not None and dl.ok else None,
        dr.reference if dr is not None and dr.ok else None, ok=ok, width=THUMB_WIDTH)


def pose_rows(poses: PoseList | None, path: Path | None) -> tuple[list[PoseRow], str]:
    """The rows of `poses` with their status read from the measurements file `path` and its
    rejects file (an earlier run of this list), and the problem that keeps the files from being
    used ("" when none): a file of another pose list leaves every row pending."""
    if poses is None:
        return [], ""
    rows = [PoseRow(i, int(pid)) for i, pid in enumerate(np.asarray(poses.pose, int))]
    row_of = {r.pose: r.index for r in rows}
    if path is None:
        return rows, ""
    try:
        if path.is_file() and path.read_bytes().strip():
            meas = read_measurements(path)
            q_list = np.atleast_2d(np.asarray(poses.q_file, float))
            for k in range(meas.n_points):
                i = row_of.get(int(meas.pose[k]))
                if i is None or meas.target[k] != "marker":
                    continue
                q = np.asarray(meas.q_file[k], float)
                if q.shape != q_list[i].shape or np.max(np.abs(q - q_list[i])) > JOINT_TOLERANCE:
                    for r in rows:
                        r.status, r.point, r.sigma = PENDING, None, None
                    return rows, (f"{path.name} belongs to another pose list (pose {int(meas.pose[k])} "
                                  "has other joint values).")
                r = rows[i]
                r.status, r.point = MEASURED, meas.xyz[k]
                r.sigma = meas.sigma[k] if meas.sigma is not None else None
        for pid, (_target, _q, reason) in read_rejects(rejects_path_for(path)).items():
            i = row_of.get(int(pid))
            if i is not None and rows[i].status != MEASURED:
                rows[i].status, rows[i].reason = REJECTED, reason
    except RoboCalError as exc:
        return rows, exc.message
    return rows, ""


def move_aside(files: list[Path], stamp: str | None = None) -> list[Path]:
    """Rename each file to `<stem>.old-<stamp>[-k]<suffix>` beside it (never over an existing
    file) and return the new paths. `stamp` defaults to the local time, YYYYmmdd-HHMMSS.
    Raises RoboCalError naming the file that cannot be moved (the ones before it are moved)."""
    stamp = stamp or time.strftime("%Y%m%d-%H%M%S")
    moved = []
    for p in files:
        target = p.with_name(f"{p.stem}.old-{stamp}{p.suffix}")
        k = 1
        while target.exists():
            target = p.with_name(f"{p.stem}.old-{stamp}-{k}{p.suffix}")
            k += 1
        try:
            p.rename(target)
        except OSError as exc:
            raise RoboCalError(f"cannot move {p.name} aside ({exc.strerror})", source=p) from None
        moved.append(target)
    return moved


def nominal_predictions(lab, Q) -> tuple[np.ndarray, np.ndarray]:
    """Marker positions (N, 3) of the lab's placed nominal robot at Q (N, n; rad / mm) in the
    left camera frame (mm), and every point of its arms (K, 3) (what the views must show)."""
    predicted = lab.nominal_robot.target_positions(Q, lab.target)
    arms, _ = arm_polyline(lab.nominal_robot, Q, lab.target)
    return predicted, arms.reshape(-1, 3)


def nominal_arm(lab, q) -> np.ndarray:
    """The lab's nominal arm at one configuration q (n,) as a polyline (P, 3), mm."""
    pts, _ = arm_polyline(lab.nominal_robot, np.atleast_2d(q), lab.target)
    return pts[0]


def choose_pose_list(robot, *, loaded_csv: Path | None, project_poses: Path | None,
                     selection) -> tuple[PoseList | None, str, str]:
    """The poses to measure with `robot`: a CSV the user loaded, else the project's poses.csv
    (`project_poses`, None when it has none), else the Pose step's `selection` (a
    PoseSelectionResult). Returns (poses, where they come from, the problem or "")."""
    try:
        if loaded_csv is not None:
            poses = read_pose_list(loaded_csv, robot)
            return poses, f"{len(poses)} poses from {loaded_csv.name}", ""
        if project_poses is not None:
            poses = read_pose_list(project_poses, robot)
            return poses, f"{len(poses)} poses from the project's poses.csv", ""
        if selection is not None:
            poses = PoseList(q_file=np.asarray(selection.q_file, float), Q=np.asarray(selection.Q, float),
                             pose=np.arange(len(selection.Q)))
            return poses, f"{len(poses)} poses from the Pose sequence step", ""
    except RoboCalError as exc:
        return None, "", f"The pose list cannot be used: {exc.message}"
    return None, "", "No pose list yet: select poses in step 4, or load a poses CSV."


def poses_needed(robot, selection) -> int:
    """The fewest poses identification needs: the Pose step's figure, else `robot`'s with its
    marker (0 for a robot without identifiable parameters)."""
    n_min = int(getattr(selection, "n_min", 0) or 0) if selection is not None else 0
    if n_min:
        return n_min
    try:
        return minimum_poses(robot)
    except RoboCalError:              # a robot without identifiable parameters: no minimum
        return 0
