"""Where a check, a re-identification or a tool identification measures, outside the virtual lab
(Qt-free; `robocal check`, `robocal reidentify` and `robocal identify-tool` use it):

- image files: the pairs `DIR/left/*`, `DIR/right/*` (paired by sorted name, as `robocal
  measure` reads them) taken at the poses of a joints file, the marker located in each pair;
- a measurements file: points measured by RoboCal or another instrument (a laser tracker's after
  `robocal import-measurements`), their joints and positions as written;
- a connected cell: a serial robot (core.robot.serial_robot) driven to each pose, a pair
  captured from two cameras (device indices, video files or image folders), the marker located.

Each gives the poses (rad / mm), their numbers, `measure(q)` -> the marker's position (mm, left
camera frame) for core.monitoring.check.run_check, and the words saying where it measured.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np

from core.errors import RoboCalError
from core.measurement.file import Measurements, read_measurements
from core.robot.model import RobotModel


@dataclass
class MeasuredPoses:
    """Poses to measure (Q: rad / mm, ids: their numbers) and how: `measure(q)` is called once per
    pose in this order and gives the marker's position (mm) or None / RoboCalError when it is not
    found. `where` says where it measures; `close()` releases the robot and cameras."""

    Q: np.ndarray
    ids: np.ndarray
    measure: Callable
    where: str
    target: str = "marker"
    closers: list[Callable] = field(default_factory=list)

    def close(self) -> None:
        for close in reversed(self.closers):
            close()

    def __enter__(self) -> "MeasuredPoses":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def measurements(self, model: RobotModel, *, progress=None) -> Measurements:
        """Every pose measured (in order), as Measurements of `target` for `model`; poses where
        the marker was not found are left out. RoboCalError when none was measured."""
        rows, xyz, reasons = [], [], []
        for k, q in enumerate(self.Q):
            if progress is not None:
                progress(k / max(len(self.Q), 1), f"measuring pose {k + 1} of {len(self.Q)}")
            try:
                p = self.measure(q)
            except RoboCalError as exc:
                if _fault(exc):
                    raise
                reasons.append(exc.problem)
                continue
            if p is None:
                reasons.append("the marker was not found")
                continue
            rows.append(k)
            xyz.append(np.asarray(p, dtype=float).reshape(3))
        if not rows:
            why = f" ({reasons[0]})" if reasons else ""
            raise RoboCalError(f"none of the {len(self.Q)} poses could be measured{why}", source=self.where,
                               hint="Check the stereo calibration, the marker and that the marker faces the cameras.")
        Q = self.Q[rows]
        return Measurements(pose=self.ids[rows], target=[self.target] * len(rows),
                            q_file=np.atleast_2d(model.q_to_file(Q)).reshape(len(Q), model.dof), xyz=np.array(xyz),
                            Q=Q, source=self.where)


def _fault(exc: RoboCalError) -> bool:
    from core.robot.driver import RobotFault
    return isinstance(exc, RobotFault)


def stereo_options(stereo, plate_mm: float | None = None) -> dict:
    """Pose-choice options (core.poses.candidates) for a real cell: its stereo rig, the marker
    plate (default: the default marker's) and the default depth range, so that only poses where
    both cameras see the whole marker facing them are chosen (as `robocal select-poses --stereo`)."""
    from core.marker.description import MarkerDescription
    from core.poses.candidates import VisibilityOptions
    from core.stereo.importers import read_any_stereo

    plate = (plate_mm, plate_mm) if plate_mm else tuple(MarkerDescription.default().plate_size)
    return {"rig": read_any_stereo(stereo).file.rig, "plate_size": plate, "visibility": VisibilityOptions()}


def _locate_point(locator, left, right, where: str):
    loc = locator.locate(left, right)
    if not loc.ok:
        raise RoboCalError(loc.reason or "the marker was not found", source=where)
    return loc.point


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
    points = iter(meas.xyz[rows])
    return MeasuredPoses(np.asarray(meas.Q, dtype=float)[rows], np.asarray(meas.pose, dtype=int)[rows],
                         lambda q: next(points), f"measurement file {path}", target)


def parse_cameras(text: str) -> tuple:
    """'LEFT,RIGHT' -> two camera specs: device indices (0), device paths, video files or image folders."""
    parts = [p.strip() for p in str(text).split(",")]
    if len(parts) != 2 or not all(parts):
        raise RoboCalError(f"expected two cameras 'LEFT,RIGHT', got {text!r}", field="--cameras",
                           hint="Give device indices (0,1), video files or image folders, left first.")
    return tuple(int(p) if p.isdigit() else p for p in parts)


def connected_cell(model: RobotModel, Q, port: str, profile: str, cameras: tuple, locator, *,
                   ids=None, target: str = "marker", reply_timeout: float = 5.0) -> MeasuredPoses:
    """The robot on serial `port` (protocol `profile`) driven to each pose of Q (rad / mm; joint
    limits checked before anything is sent), a pair captured from `cameras` (left, right) once it
    settled, the marker located by `locator`. A robot or connection fault ends the run
    (core.robot.driver.RobotFault). Close it to stop using the robot and cameras."""
    from core.measurement.capture import open_stereo
    from core.robot.driver import check_joint_values
    from core.robot.serial_robot import SerialRobot

    Q = np.atleast_2d(np.asarray(Q, dtype=float))
    for k, q in enumerate(Q):
        check_joint_values(model, q, f"check pose {k}")
    driver = SerialRobot(model, port, profile, reply_timeout=reply_timeout)
    driver.connect()
    try:
        source = open_stereo(*cameras)
    except BaseException:
        driver.disconnect()
        raise
    where = f"serial robot on {port} ({driver.profile.name}), cameras {cameras[0]}, {cameras[1]}"
    motion = AheadMotion(driver, Q)

    def measure(q):
        motion.reach(q)
        frames = source.capture()
        motion.start_next()                 # the robot moves on while the marker is located in this pair
        return _locate_point(locator, frames.left, frames.right, where)
    ids = np.arange(len(Q)) if ids is None else np.asarray(ids, dtype=int)
    return MeasuredPoses(Q, ids, measure, where, target, [motion.finish, driver.disconnect, source.close])


class AheadMotion:
    """Moves a driver through planned poses, one move ahead: once a pose's pair is captured, the
    move to the next planned pose starts on a thread while the pair is processed. `reach(q)` waits
    for that move when q is the next planned pose, else moves there itself; a fault of a move made
    ahead is raised by the next `reach` (or `finish`)."""

    def __init__(self, driver, plan):
        self.driver, self.plan = driver, np.atleast_2d(np.asarray(plan, dtype=float))
        self.next = 0                    # index in plan of the pose reached next
        self._thread = None
        self._error: BaseException | None = None

    def _join(self) -> None:
        if self._thread is not None:
            self._thread.join()
            self._thread = None
        if self._error is not None:
            error, self._error = self._error, None
            raise error

    def reach(self, q) -> None:
        q = np.asarray(q, dtype=float)
        ahead = self._thread is not None
        self._join()
        planned = self.next < len(self.plan) and np.array_equal(q, self.plan[self.next])
        if not (ahead and planned):
            self.driver.move_to(q)
        self.next = self.next + 1 if planned else len(self.plan)

    def start_next(self) -> None:
        import threading

        if self.next >= len(self.plan) or self.driver.stopped:
            return
        target = self.plan[self.next]

        def move():
            try:
                self.driver.move_to(target)
            except BaseException as exc:    # handed to the caller by the next reach()
                self._error = exc
        self._thread = threading.Thread(target=move, name="robocal-move-ahead", daemon=True)
        self._thread.start()

    def finish(self) -> None:
        """Wait for a move made ahead (its fault is dropped: nothing is measured after it)."""
        if self._thread is not None:
            self._thread.join()
            self._thread = None
        self._error = None
