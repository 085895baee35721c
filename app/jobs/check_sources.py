"""Where a check, a re-identification or a tool identification measures, outside the virtual lab
(Qt-free; `robocal check`, `robocal reidentify` and `robocal identify-tool` use it):

- image files: the pairs `DIR/left/*`, `DIR/right/*` (paired by sorted name, as `robocal
  measure` reads them) taken at the poses of a joints file, the marker located in each pair;
- a measurements file: points measured by RoboCal or another instrument (a laser tracker's after
  `robocal import-measurements`), their joints and positions as written;
- a connected cell: a serial robot (core.robot.serial_robot) and two cameras (device indices,
  video files or image folders) opened here, then measured as the Check page measures its cell
  (app.jobs.cell_measure.CellMeasure: driven to each pose, a pair captured, the marker located).

Each gives the poses (rad / mm), their numbers, `measure(q)` -> the marker's position (mm, left
camera frame) for core.monitoring.check.run_check, and the words saying where it measured.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np

from app.jobs.cell_measure import CellMeasure, cell_options
from core.errors import RoboCalError
from core.measurement.file import Measurements, read_measurements
from core.measurement.point import MeasuredPoint, located_point
from core.robot.model import RobotModel


@dataclass
class MeasuredPoses:
    """Poses to measure (Q: rad / mm, ids: their numbers) and how: `measure(q)` is called once per
    pose in this order and gives the marker's position (mm) or None / RoboCalError when it is not
    found. `where` says where it measures; `cell` is the connected cell's measure (None for files);
    `close()` releases the robot and cameras (the robot is stopped first when the block they were
    used in failed)."""

    Q: np.ndarray
    ids: np.ndarray
    measure: Callable
    where: str
    target: str = "marker"
    closers: list[Callable] = field(default_factory=list)
    cell: CellMeasure | None = None

    def close(self) -> None:
        """Run the closers in their order (a move made ahead is waited for before the robot is
        disconnected); each runs even when one before it failed (the first failure is raised)."""
        failure = None
        for close in self.closers:
            try:
                close()
            except Exception as e:      # noqa: BLE001 — the cameras are closed even if the robot's link failed
                failure = failure or e
        if failure is not None:
            raise failure

    def __enter__(self) -> "MeasuredPoses":
        return self

    def __exit__(self, kind, *exc) -> None:
        if kind is not None and self.cell is not None:
            self.cell.driver.stop()            # interrupted or failed: nothing more moves
        self.close()

    def cancelled(self) -> Callable[[], bool] | None:
        """The cancel check of a run over these poses: a fault or stop of the connected robot."""
        return self.cell.cancelled() if self.cell is not None else None

    def raise_fault(self) -> None:
        """The robot fault that ended a run over the connected cell (core.robot.driver.RobotFault)."""
        if self.cell is not None:
            self.cell.raise_fault()

    def measurements(self, model: RobotModel, *, progress=None) -> Measurements:
        """Every pose measured (in order), as Measurements of `target` for `model`; poses where
        the marker was not found are left out. RoboCalError when none was measured; RobotFault
        when the connected robot faulted (nothing is kept)."""
        rows, xyz, reasons = [], [], []
        ended = self.cancelled() or (lambda: False)
        for k, q in enumerate(self.Q):
            if ended():
                break
            if progress is not None:
                progress(k / max(len(self.Q), 1), f"measuring pose {k + 1} of {len(self.Q)}")
            try:
                p = self.measure(q)
            except RoboCalError as exc:
                reasons.append(exc.problem)
                continue
            if p is None:
                reasons.append("the marker was not found")
                continue
            rows.append(k)
            xyz.append(np.asarray(p, dtype=float).reshape(3))
        self.raise_fault()
        if not rows:
            why = f" ({reasons[0]})" if reasons else ""
            raise RoboCalError(f"none of the {len(self.Q)} poses could be measured{why}", source=self.where,
                               hint="Check the stereo calibration, the marker and that the marker faces the cameras.")
        Q = self.Q[rows]
        return Measurements(pose=self.ids[rows], target=[self.target] * len(rows),
                            q_file=np.atleast_2d(model.q_to_file(Q)).reshape(len(Q), model.dof), xyz=np.array(xyz),
                            Q=Q, source=self.where)


def stereo_options(stereo, plate_mm: float | None = None) -> dict:
    """Pose-choice options for a cell given by its stereo calibration file (any format RoboCal
    reads): its rig and the marker plate (`plate_mm`; default the shipped marker's), so that only
    poses where both cameras see the whole marker facing them are chosen (app.jobs.cell_measure.cell_options)."""
    from core.stereo.importers import read_any_stereo
    return cell_options(read_any_stereo(stereo).file.rig, plate_mm=plate_mm)


def _locate_point(locator, left, right, where: str):
    loc = locator.locate(left, right)
    if not loc.ok:
        raise RoboCalError(loc.reason or "the marker was not found", source=where)
    return located_point(loc)


def image_files(model: RobotModel, joints, images, locator, *, target: str = "marker") -> MeasuredPoses:
    """The poses of the joints file `joints` (pose,q1..qn; deg / mm) with their pairs in
    `images`/left and `images`/right (paired by sorted file name, one pair per row), located by
    `locator` (core.marker.location.MarkerLocator)."""
    from core.images import read_camera_image
    from core.poses.file import read_poses
    from core.stereo.image_files import pair_images

    poses = read_poses(joints, model)
    images = Path(images)
    if not images.is_dir():
        raise RoboCalError("no such folder", source=images, hint="Give the folder holding left/ and right/.")
    pairs, _ = pair_images(images / "left", images / "right")
    if len(pairs) != len(poses):
        raise RoboCalError(f"{len(pairs)} image pairs in {images} but {len(poses)} poses in the joints file",
                           source=joints, hint="Give one row per image pair, in the order of the file names.")
    order = iter(pairs)
    size = locator.rect.image_size

    def measure(q):
        left, right = next(order)
        return _locate_point(locator, read_camera_image(left, "left", size), read_camera_image(right, "right", size),
                             str(left))
    return MeasuredPoses(np.asarray(poses.Q, dtype=float), np.asarray(poses.pose, dtype=int), measure,
                         f"image files in {images}", target)


def measurement_file(model: RobotModel, path, target: str) -> MeasuredPoses:
    """The points of `target` in a measurements file (RoboCal's, or another instrument's after
    `robocal import-measurements`), at the joints written beside them."""
    meas = read_measurements(path, model)
    meas = meas.with_robot(model) if meas.Q is None else meas
    names = list(dict.fromkeys(meas.target))
    rows = [k for k, t in enumerate(meas.target) if t == target]
    if not rows:
        raise RoboCalError(f"the file holds no point of target '{target}' (its targets: {', '.join(names)})",
                           source=path, field="target",
                           hint="Give the measurements of the mounted tool's target, or name the tool with --tool.")
    sigma = meas.sigma[rows] if meas.sigma is not None else [None] * len(rows)
    points = iter([MeasuredPoint(p, None if s is None else np.diag(np.square(s))) for p, s in zip(meas.xyz[rows], sigma)])
    return MeasuredPoses(np.asarray(meas.Q, dtype=float)[rows], np.asarray(meas.pose, dtype=int)[rows],
                         lambda q: next(points), f"measurement file {path}", target)


def require_within_limits(model: RobotModel, Q) -> np.ndarray:
    """The poses Q (rad / mm, one per row), each checked against the robot's joint limits before
    anything moves or is asked (RoboCalError naming the first pose outside them)."""
    from core.robot.driver import check_joint_values

    Q = np.atleast_2d(np.asarray(Q, dtype=float))
    for k, q in enumerate(Q):
        check_joint_values(model, q, f"pose {k}")
    return Q


def connected_cell(model: RobotModel, Q, port: str, profile: str, cameras: tuple, locator, *,
                   ids=None, target: str = "marker", reply_timeout: float = 5.0) -> MeasuredPoses:
    """The robot on serial `port` (protocol `profile`) and the `cameras` (left, right: device
    indices, device paths, video files or image folders), opened as the Setup page opens them
    (app.hardware), measured as the Check page measures its cell (app.jobs.cell_measure.CellMeasure):
    driven to each pose of Q (rad / mm; the joint limits of every pose checked before the robot
    is even connected), a pair captured once it settled, the marker located by `locator` while
    it moves on to the next pose. A robot or connection fault ends the run with the points
    measured (`MeasuredPoses.raise_fault`). Close it to stop using the robot and cameras."""
    from app.hardware import SERIAL, SOURCES, CameraChoice, LiveCameras, RobotChoice, open_serial_robot
    Q = require_within_limits(model, Q)
    driver = open_serial_robot(model, RobotChoice(SERIAL, port, profile), reply_timeout=reply_timeout)
    try:
        live = LiveCameras.open(CameraChoice(SOURCES, str(cameras[0]), str(cameras[1])))
    except BaseException:
        driver.disconnect()
        raise
    where = f"serial robot on {port} ({driver.profile.name}), cameras {cameras[0]}, {cameras[1]}"
    cell = CellMeasure(driver, live, locator, plan=Q)
    ids = np.arange(len(Q)) if ids is None else np.asarray(ids, dtype=int)
    return MeasuredPoses(Q, ids, cell, where, target, [cell.finish, driver.disconnect, live.close], cell=cell)
