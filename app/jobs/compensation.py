"""The Compensation step's work on a worker (plain Python: the page only draws what comes back).

Points typed by the technician (robot base frame, camera frame, or a fixture located by the Check
step: fixture_pose.json) or read from a program (Cartesian targets, core.compensation.targets, or
a joint program taught with the nominal model) are reached
with the calibrated model (core.compensation.ik) and with the nominal one (what the controller
would do: `nominal_in_cell`), with the predicted error of the calibrated landing from the
calibration's covariance. Go to point and the accuracy map move the project's robot — the
virtual lab's true robot, or the connected robot (a serial controller, sim-robot) — and measure
the marker with the cameras (`lab_measure`, `robot_measure`); every landing says where it was
measured.

Joint values: internal (rad / mm) unless named `_file` (deg / mm). Points: mm, measurement frame
(left camera) unless said otherwise.
"""
from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from core.compensation.accuracy_map import AccuracyMap, nominal_in_cell, run_accuracy_map
from core.compensation.accuracy_map_file import NAME as MAP_NAME, write_accuracy_map
from core.compensation.ik import frame_to_world, solve_ik
from core.compensation.prediction import point_covariances
from core.compensation.targets import read_targets
from core.compensation.workspace_grid import workspace_grid
from core.errors import RoboCalError, UsageError
from core.files import read_text
from core.fixtures.file import read_fixture_pose
from core.measurement.file import read_measurements
from core.monitoring.uncertainty import CalibrationUncertainty, calibration_uncertainty
from core.poses.file import read_poses, write_poses
from core.robot.file import read_robot
from core.robot.model import RobotModel
from core.task import Monitor

FIXTURE_NAME = "fixture_pose.json"
PROGRAM_NAME = "corrected_program.csv"


@dataclass
class Cell:
    """The calibrated robot of the project, the nominal one placed where the cameras found it,
    the calibration's uncertainty (None when the file has no covariance) and the marker target."""

    calibrated: RobotModel
    nominal: RobotModel
    unc: CalibrationUncertainty | None
    source: str
    target: str = "marker"
    measured_Q: np.ndarray | None = None       # the calibration's poses (rad / mm): starting joints

    def nearest_measured(self, world) -> np.ndarray | None:
        """Per point (n, 3) mm, measurement frame, the calibration pose whose marker was nearest
        (n, dof) — the inverse kinematics starts there, so the marker faces the cameras."""
        if self.measured_Q is None or not len(self.measured_Q):
            return None
        seen = self.calibrated.target_positions(self.measured_Q, self.target)
        nearest = np.linalg.norm(np.asarray(world)[:, None, :] - seen[None], axis=2).argmin(axis=1)
        return self.measured_Q[nearest]


def load_cell(calibrated_path, nominal: RobotModel, measurements_path=None) -> Cell:
    """Read the calibrated robot (RoboCalError when it cannot be read) and place the nominal one;
    the calibration's poses from `measurements_path` when it exists."""
    calibrated = read_robot(calibrated_path)
    try:
        unc = calibration_uncertainty(calibrated, source=calibrated_path)
    except RoboCalError:
        unc = None
    target = "marker" if "marker" in calibrated.targets else next(iter(calibrated.targets), "")
    if not target:
        raise RoboCalError("the calibrated robot has no target point", source=calibrated_path, field="targets",
                           hint="Use the calibrated.json the Identification step wrote.")
    Q = None
    if measurements_path is not None and Path(measurements_path).is_file():
        Q = read_measurements(measurements_path, calibrated).Q
    return Cell(calibrated, nominal_in_cell(nominal, calibrated), unc, str(calibrated_path), target, Q)


@dataclass
class CompensatedPoint:
    """One point: its target (measurement frame), the nominal and the corrected joints (NaN when
    that model cannot reach it, `note` says why), the predicted error of the corrected landing
    (mm, 1σ of the 3D position from the calibration's covariance; NaN without one) and, after Go
    to point, where the marker landed with the corrected joints (`landed`) and with the nominal
    ones (`landed_nominal`), and how that was measured."""

    name: str
    target: np.ndarray
    q_nominal: np.ndarray
    q_corrected: np.ndarray
    predicted_mm: float
    note: str = ""
    landed: np.ndarray | None = None
    landed_nominal: np.ndarray | None = None
    measured_by: str = ""

    @property
    def reachable(self) -> bool:
        return bool(np.all(np.isfinite(self.q_corrected)))

    def joints(self, nominal: bool = False) -> np.ndarray:
        return self.q_nominal if nominal else self.q_corrected

    def error_mm(self, nominal: bool = False) -> float:
        """|landed − target| (mm) with the corrected (or the nominal) joints; NaN before Go to point
        or when the marker was not found."""
        landed = self.landed_nominal if nominal else self.landed
        return float(np.linalg.norm(landed - self.target)) if landed is not None else float("nan")


def frame_of(choice: str, fixture_path=None):
    """The frame a typed point is in: "base", "camera", or "fixture" (the 4x4 pose of
    fixture_pose.json's frame in the robot base frame; RoboCalError when it is missing)."""
    if choice in ("base", "camera"):
        return "measurement" if choice == "camera" else "base"
    if choice != "fixture":
        raise RoboCalError(f"unknown frame '{choice}'", field="frame", hint="Choose base, camera or fixture.")
    if fixture_path is None or not Path(fixture_path).is_file():
        raise RoboCalError("no located fixture in the project", source=fixture_path, field="frame",
                           hint="Locate the fixture on the Check page first (it writes fixture_pose.json).")
    return read_fixture_pose(fixture_path).frame.matrix


def predicted_errors_mm(cell: Cell, Q) -> np.ndarray:
    """1σ of the 3D position of the marker at each row of Q (n, dof) from the calibration's
    parameter covariance (mm, √trace of core.compensation.prediction's covariance); NaN for rows
    with NaN joints or without a covariance."""
    Q = np.atleast_2d(np.asarray(Q, dtype=float))
    out = np.full(len(Q), np.nan)
    ok = np.all(np.isfinite(Q), axis=1)
    if cell.unc is None or not ok.any():
        return out
    S = point_covariances(cell.calibrated, cell.unc, Q[ok], cell.target)
    out[ok] = np.sqrt(np.clip(np.trace(S, axis1=1, axis2=2), 0.0, None))
    return out


def compensate_points(cell: Cell, names, points, frame="measurement", *, rotations=None, hints=None, progress=None,
                      cancelled=None) -> list[CompensatedPoint]:
    """Reach `points` (n, 3) mm in `frame` ("base", "measurement", or a fixture's 4x4 pose in the
    base frame), with the marker frame's orientations `rotations` (n, 3, 3) in that frame when
    given (else positions only), with the calibrated model (from `hints` (n, dof), else from the
    nearest calibration pose, else each from the previous point) and with the nominal one (from
    the corrected joints: the same branch)."""
    monitor = Monitor(progress, cancelled)
    points = np.atleast_2d(np.asarray(points, dtype=float))
    names = list(names)
    if len(names) != len(points):
        raise UsageError(f"{len(names)} names for {len(points)} points")
    if hints is None:
        T = frame_to_world(cell.calibrated, frame)
        hints = cell.nearest_measured(points @ T[:3, :3].T + T[:3, 3])
    monitor.step(0.1, f"joints of {len(points)} points with the calibrated model")
    after = solve_ik(cell.calibrated, points, rotations, tcp=cell.target, frame=frame, hint=hints)
    world = after.targets_world[:, :3, 3]
    monitor.step(0.6, "the same points with the nominal model")
    before = solve_ik(cell.nominal, world, None if rotations is None else after.targets_world[:, :3, :3],
                      tcp=cell.target, frame="measurement",
                      hint=np.where(after.ok[:, None], after.Q, after.Q if hints is None else hints))
    q_after = np.where(after.ok[:, None], after.Q, np.nan)
    q_before = np.where(before.ok[:, None], before.Q, np.nan)
    predicted = predicted_errors_mm(cell, q_after)
    monitor.step(1.0, "done")
    out = []
    for i, name in enumerate(names):
        note = (f"calibrated model: {after.reason[i]}" if after.reason[i]
                else f"nominal model: {before.reason[i]}" if before.reason[i] else "")
        out.append(CompensatedPoint(str(name), world[i], q_before[i], q_after[i], float(predicted[i]), note))
    return out


def program_points(cell: Cell, path) -> tuple[list[str], np.ndarray, np.ndarray]:
    """A joint program taught or generated with the nominal model (pose,q1..qn; deg / mm): its
    pose names, the points the nominal model meant (mm, measurement frame, where the cameras
    found the robot) and the taught joints as hints (rad / mm)."""
    poses = read_poses(path, cell.nominal)
    meant = cell.nominal.target_positions(poses.Q, cell.target)
    return [str(int(p)) for p in poses.pose], meant, poses.Q


def is_targets_file(path) -> bool:
    """True when the file's header names Cartesian targets (name,x,y,z…), not joints (pose,q1…)."""
    for line in read_text(path, "a program (targets or joints CSV)").splitlines():
        line = line.strip()
        if line and not line.startswith("#"):
            return {"x", "y", "z"} <= {c.strip() for c in line.split(",")}
    return False


def compensate_program(cell: Cell, path, frame="measurement", *, progress=None, cancelled=None) -> list[CompensatedPoint]:
    """A program file corrected: Cartesian targets (core.compensation.targets: name,x,y,z
    [,roll,pitch,yaw][,q1..qn], in `frame`) or a joint program taught with the nominal model
    (`program_points`), each point reached with both models."""
    if is_targets_file(path):
        targets = read_targets(path, cell.calibrated.dof)
        hints = None if targets.hint_file is None else cell.calibrated.q_from_file(targets.hint_file)
        rotations = targets.rotations if cell.calibrated.dof >= 6 else None
        return compensate_points(cell, targets.names, targets.xyz, frame, rotations=rotations, hints=hints,
                                 progress=progress, cancelled=cancelled)
    names, meant, taught = program_points(cell, path)
    return compensate_points(cell, names, meant, "measurement", hints=taught, progress=progress,
                             cancelled=cancelled)


def write_corrected_program(path, cell: Cell, points: list[CompensatedPoint]) -> Path:
    """The corrected joints as a joint program (pose,q1..qn; deg / mm; atomic). Refuses, naming
    them, points the calibrated model cannot reach: a program is never silently shortened."""
    bad = [p for p in points if not p.reachable]
    if not points:
        raise RoboCalError("no points to write", hint="Type a point or load a program first.")
    if bad:
        names = ", ".join(p.name for p in bad[:5]) + (" …" if len(bad) > 5 else "")
        raise RoboCalError(f"{len(bad)} point(s) cannot be reached with the calibrated model: {names}",
                           source=path, hint=bad[0].note or "Remove them or move them inside the workspace.")
    return write_poses(path, cell.calibrated.q_to_file(np.array([p.q_corrected for p in points])))


# -- moving and measuring --------------------------------------------------------------------

def lab_measure(lab, images, *, seed: int = 0):
    """(measure, where) on the virtual lab: its true robot at q, the marker located in the
    rendered pair (images = (trained marker, stereo rectification)), or the lab's true marker
    position when the project has no trained marker and stereo calibration."""
    from app.lab import ideal_measure, image_measure

    if images is not None:
        from core.marker.location import MarkerLocator
        return (image_measure(lab, MarkerLocator(*images).locate, seed=seed),
                "virtual lab, located in the rendered camera images")
    return ideal_measure(lab, sigma_mm=0.0, seed=seed), "virtual lab, the true marker position (no trained marker)"


def robot_measure(driver, source, images, *, rendered: bool = False, stop=None):
    """(measure, where) over a connected robot: move it (`driver.move_to`, limits checked by the
    driver), capture from `source` (the cameras, or, `rendered`, the virtual lab's cameras
    rendering the joints the robot reports) and locate the marker (images = (trained marker,
    stereo rectification)). A Stop raises before the next motion."""
    from core.marker.location import MarkerLocator

    locator = MarkerLocator(*images)

    def measure(q):
        if driver.stopped or (stop is not None and stop()):
            raise RoboCalError("the robot was stopped", source=driver.info.name,
                               hint="Check that the way is clear, then resume.")
        driver.move_to(q)
        frames = source.capture()
        loc = locator.locate(frames.left, frames.right)
        return loc.point if loc.ok else None
    cameras = ("the virtual lab's cameras rendering the joints it reports" if rendered
               else "located in the camera images")
    return measure, f"robot {driver.info.name} ({getattr(driver, 'port', '') or driver.name}), {cameras}"


def go_to_point(point: CompensatedPoint, measure, measured_by: str, *, nominal: bool = False, progress=None,
                cancelled=None) -> CompensatedPoint:
    """Move to the point's corrected joints (or, `nominal`, to the joints the nominal model
    computes: what the controller alone would do) and measure where the marker landed."""
    monitor = Monitor(progress, cancelled)
    q = point.joints(nominal)
    model = "nominal" if nominal else "calibrated"
    if not np.all(np.isfinite(q)):
        raise RoboCalError(f"point {point.name} cannot be reached with the {model} model",
                           hint=point.note or "Choose a point inside the workspace.")
    monitor.step(0.1, f"moving to point {point.name} with the {model} model")
    landed = measure(q)
    monitor.step(1.0, "measured")
    landed = None if landed is None else np.asarray(landed, dtype=float)
    return replace(point, measured_by=measured_by,
                   note=point.note if landed is not None else f"marker not found by the cameras ({model} model)",
                   **{"landed_nominal" if nominal else "landed": landed})


@dataclass
class MapRun:
    """An accuracy map and the file it was written to (None when nothing was written)."""

    amap: AccuracyMap
    path: Path | None


def measure_accuracy_map(cell: Cell, measurements_path, measure, measured_by: str, out_folder, *, count: int = 20,
                         keep=None, progress=None, cancelled=None) -> MapRun:
    """A grid of `count` targets in the workspace of the calibration's measurements, reached with
    both models and measured (`measure`); written to `out_folder`/accuracy_map.json (atomic)
    unless cancelled or nothing was measured, so a good map is never replaced by a failed one."""
    monitor = Monitor(progress, cancelled)
    if measurements_path is None or not Path(measurements_path).is_file():
        raise RoboCalError("no measurements in the project", source=measurements_path,
                           hint="The accuracy map takes its targets where the calibration measured: run the "
                                "Measurement step first.")
    meas = read_measurements(measurements_path, cell.calibrated)
    monitor.step(0.0, "targets in the calibrated workspace")
    grid = workspace_grid(cell.calibrated, meas.Q, count=count, target=cell.target, keep=keep)
    if not len(grid.points):
        raise RoboCalError("no target of the grid can be reached inside the joint limits", source=measurements_path,
                           hint="Check the joint limits of the robot file.")
    amap = run_accuracy_map(cell.nominal, cell.calibrated, grid, measure, measured_by=measured_by,
                            robot=Path(cell.source).name, progress=monitor.sub(0.05, 1.0), cancelled=cancelled)
    path = None
    if not amap.cancelled and amap.both.any():
        path = write_accuracy_map(Path(out_folder) / MAP_NAME, amap, cell.calibrated)
    return MapRun(amap, path)
