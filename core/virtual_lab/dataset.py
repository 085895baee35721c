"""`simulate_dataset`: a complete virtual-lab dataset on disk, with the ground truth.

Layout of the output folder (same seed => byte-identical files):
    checkerboard/left/pair_000.png …   checkerboard/right/pair_000.png …
    marker/training.png
    poses/left/pose_000.png …          poses/right/pose_000.png …
    poses/joints.csv                   header `pose,q1,...,qn`, degrees (mm for prismatic)
    truth.json                         stereo, board, true and nominal robot, marker, poses, …
Everything is written into a hidden temporary sibling folder that is renamed to the output
folder only when complete, so a failed or cancelled run leaves no half dataset behind. An
existing output folder is replaced only if it is empty or holds a previous dataset.
"""
from __future__ import annotations

import os
import shutil
import tempfile
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from core.errors import RoboCalError, UsageError
from core.files import atomic_write_bytes, atomic_write_json, atomic_write_text
from core.images import encode_png
from core.robot.model import RobotModel
from core.robot.file import robot_to_dict
from core.task import Monitor
from core.transforms import matrix_to_rpy
from core.virtual_lab.lab import VirtualLab
from core.virtual_lab.rig import rig_to_dict

TRUTH_FORMAT = "robocal.truth/1"
# Random streams, one per purpose, so each part depends only on the seed and its index.
_BOARD_POSES, _ROBOT_POSES, _BOARD_IMAGES, _POSE_IMAGES, _TRAINING = range(1, 6)


@dataclass
class SimulationResult:
    """What `simulate_dataset` wrote (paths are final, inside `out_dir`)."""

    out_dir: Path
    seed: int
    noise: float
    robot_name: str
    checkerboard_left: list[Path] = field(default_factory=list)
    checkerboard_right: list[Path] = field(default_factory=list)
    pose_left: list[Path] = field(default_factory=list)
    pose_right: list[Path] = field(default_factory=list)
    training_image: Path | None = None
    joints_csv: Path | None = None
    truth_path: Path | None = None
    board_poses: np.ndarray = field(default_factory=lambda: np.zeros((0, 4, 4)))   # board -> left camera
    joints: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))           # rad / mm
    marker_positions: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))  # mm, left camera
    truth: dict = field(default_factory=dict)

    @property
    def pairs(self) -> int:
        return len(self.checkerboard_left)

    @property
    def poses(self) -> int:
        return len(self.pose_left)

    def summary(self) -> dict:
        """Counts and paths (strings), e.g. for `robocal simulate --json`."""
        return {
            "out": str(self.out_dir),
            "seed": self.seed,
            "noise": self.noise,
            "robot": self.robot_name,
            "checkerboard_pairs": self.pairs,
            "poses": self.poses,
            "checkerboard_left": str(self.out_dir / "checkerboard" / "left"),
            "checkerboard_right": str(self.out_dir / "checkerboard" / "right"),
            "poses_left": str(self.out_dir / "poses" / "left"),
            "poses_right": str(self.out_dir / "poses" / "right"),
            "training_image": str(self.training_image) if self.training_image else None,
            "joints": str(self.joints_csv) if self.joints_csv else None,
            "truth": str(self.truth_path) if self.truth_path else None,
        }


def _stream(seed: int, purpose: int, index: int | None = None) -> np.random.Generator:
    key = [int(seed), purpose] if index is None else [int(seed), purpose, int(index)]
    return np.random.default_rng(np.random.SeedSequence(key))


def _check_output(out: Path) -> None:
    if out.exists() and not out.is_dir():
        raise RoboCalError("exists and is not a folder", source=out, hint="Give a folder for the dataset.")
    if out.is_dir():
        if not os.access(out, os.W_OK | os.X_OK):
            raise RoboCalError("the folder is not writable", source=out, hint="Choose a folder you can write to.")
        entries = list(out.iterdir())
        if entries and not (out / "truth.json").is_file():
            raise RoboCalError("the folder is not empty and holds no virtual-lab dataset", source=out,
                               hint="Choose an empty or new folder (only a previous dataset is replaced).")


def _make_temp(out: Path) -> Path:
    parent = out.parent if str(out.parent) else Path(".")
    for ancestor in [parent, *parent.parents]:
        if ancestor.exists():
            if not ancestor.is_dir():
                raise RoboCalError(f"cannot write the dataset folder: {ancestor} is a file, not a folder",
                                   source=out, hint="Choose a folder you can write to.")
            break
    try:
        parent.mkdir(parents=True, exist_ok=True)
        tmp = Path(tempfile.mkdtemp(prefix=f".{out.name}.partial-", dir=parent))
        os.chmod(tmp, 0o777 & ~_umask())     # mkdtemp makes it private; the dataset is not
        return tmp
    except OSError as exc:
        raise RoboCalError(f"cannot write the dataset folder ({exc.strerror or exc})", source=out,
                           hint="Choose a folder you can write to.") from exc


def _umask() -> int:
    """The process umask, read without changing it (os.umask would race with other threads)."""
    try:
        for line in Path("/proc/self/status").read_text().splitlines():
            if line.startswith("Umask:"):
                return int(line.split()[1], 8)
    except (OSError, ValueError, IndexError):
        pass
    return 0o022


def _publish(tmp: Path, out: Path) -> None:
    """Rename the finished temporary folder to `out` (replacing an empty or old dataset)."""
    try:
        if out.is_dir() and any(out.iterdir()):
            old = Path(tempfile.mkdtemp(prefix=f".{out.name}.old-", dir=out.parent))
            os.replace(out, old / "dataset")
            try:
                os.replace(tmp, out)
            except OSError:
                os.replace(old / "dataset", out)
                raise
            shutil.rmtree(old, ignore_errors=True)
        else:
            os.replace(tmp, out)
    except OSError as exc:
        raise RoboCalError(f"cannot move the finished dataset into place ({exc.strerror or exc})", source=out,
                           hint="Check the permissions of the folder and its parent.") from exc


def simulate_dataset(out_dir: str | Path, robot: RobotModel | str | Path | None = None, seed: int = 0,
                     pairs: int = 20, poses: int = 40, noise: float = 0.5, progress=None,
                     cancelled=None, configurations: np.ndarray | None = None) -> SimulationResult:
    """Render a virtual-lab dataset into `out_dir` and return what was written.

    `robot` is a nominal robot model, a robot file, or None (educational 6R preset); the
    virtual lab places it in front of the cameras and derives the true robot from `seed`.
    `configurations` (M, n), internal units (rad / mm): the robot poses to render instead of
    `poses` random visible ones (e.g. a selected pose sequence)."""
    if configurations is not None:
        configurations = np.atleast_2d(np.asarray(configurations, dtype=float))
        poses = len(configurations)
    if pairs < 0 or poses < 0:
        raise UsageError(f"counts must not be negative (pairs={pairs}, poses={poses})")
    if not noise >= 0:
        raise UsageError(f"noise must be zero or positive (grey levels), got {noise}")
    if seed < 0:
        raise UsageError(f"seed must be zero or positive, got {seed}")
    monitor = Monitor(progress, cancelled)
    out = Path(out_dir)
    _check_output(out)
    monitor.step(0.0, "building the virtual lab")
    lab = VirtualLab.create(robot, seed=seed, noise=noise)
    tmp = _make_temp(out)
    try:
        if configurations is not None and configurations.shape[1] != lab.true_robot.dof:
            raise UsageError(f"the poses have {configurations.shape[1]} joint values, the robot "
                             f"{lab.true_robot.dof} joints")
        result = _write(lab, tmp, out, seed, pairs, poses, noise, monitor, configurations)
        monitor.check()
        _publish(tmp, out)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    monitor.step(1.0, "done")
    return result


def _write(lab: VirtualLab, tmp: Path, out: Path, seed: int, pairs: int, poses: int, noise: float,
           monitor: Monitor, configurations: np.ndarray | None = None) -> SimulationResult:
    total = pairs + poses + 3
    done = 0

    def step(msg):
        nonlocal done
        done += 1
        monitor.step(done / total, msg)

    board_poses = lab.random_board_poses(pairs, _stream(seed, _BOARD_POSES)) if pairs else []
    if configurations is not None:
        Q = configurations
    else:
        Q = lab.random_visible_poses(poses, _stream(seed, _ROBOT_POSES)) if poses else np.zeros((0, lab.true_robot.dof))
    step("chose board poses and robot configurations")
    res = SimulationResult(out_dir=out, seed=seed, noise=noise, robot_name=lab.nominal_robot.name)
    board_entries = []
    for i, pose in enumerate(board_poses):
        left, right = lab.render_checkerboard_pair(pose, _stream(seed, _BOARD_IMAGES, i))
        name = f"pair_{i:03d}.png"
        for side, img, paths in (("left", left, res.checkerboard_left), ("right", right, res.checkerboard_right)):
            atomic_write_bytes(tmp / "checkerboard" / side / name, encode_png(img))
            paths.append(out / "checkerboard" / side / name)
        board_entries.append({"left": f"checkerboard/left/{name}", "right": f"checkerboard/right/{name}",
                              "pose": np.asarray(pose).tolist()})
        step(f"checkerboard pair {i + 1}/{pairs}")

    training = lab.render_training_image(_stream(seed, _TRAINING))
    atomic_write_bytes(tmp / "marker" / "training.png", encode_png(training))
    res.training_image = out / "marker" / "training.png"
    step("marker training image")

    robot = lab.true_robot
    q_file = np.round(robot.q_to_file(Q), 3).reshape(len(Q), robot.dof)
    Q = robot.q_from_file(q_file).reshape(len(Q), robot.dof)
    markers = robot.target_positions(Q, lab.target) if len(Q) else np.zeros((0, 3))
    pose_entries = []
    for i, q in enumerate(Q):
        left, right = lab.render_marker_pair(q, _stream(seed, _POSE_IMAGES, i))
        name = f"pose_{i:03d}.png"
        for side, img, paths in (("left", left, res.pose_left), ("right", right, res.pose_right)):
            atomic_write_bytes(tmp / "poses" / side / name, encode_png(img))
            paths.append(out / "poses" / side / name)
        pose_entries.append({"pose": i, "left": f"poses/left/{name}", "right": f"poses/right/{name}",
                             "q": [float(v) for v in q_file[i]],
                             "marker": [float(v) for v in markers[i]]})
        step(f"robot pose {i + 1}/{poses}")

    header = "pose," + ",".join(f"q{j + 1}" for j in range(robot.dof))
    lines = [header] + [f"{i}," + ",".join(f"{v:.3f}" for v in row) for i, row in enumerate(q_file)]
    atomic_write_text(tmp / "poses" / "joints.csv", "\n".join(lines) + "\n")
    res.joints_csv = out / "poses" / "joints.csv"
    for folder in ("checkerboard/left", "checkerboard/right", "poses/left", "poses/right", "marker"):
        (tmp / folder).mkdir(parents=True, exist_ok=True)

    errors = lab.errors.to_dict()
    base_xyz, base_rpy = lab.base_error[:3, 3], np.rad2deg(matrix_to_rpy(lab.base_error[:3, :3]))
    errors["base"] = {"xyz": [float(v) for v in base_xyz], "rpy": [float(v) for v in base_rpy],
                      "note": "true base = nominal base · this transform"}
    training_info = {"image": "marker/training.png", **lab.training_geometry()}
    truth = {
        "format": TRUTH_FORMAT,
        "generator": "robocal simulate (virtual lab)",
        "seed": int(seed),
        "noise": float(noise),
        "units": {"length": "mm", "angle": "deg"},
        "frame": "left camera (x right, y down, z forward), mm",
        "stereo": rig_to_dict(lab.rig),
        "board": {**lab.board.to_dict(), "margin_squares": 1},
        "robot": robot_to_dict(robot),
        "nominal_robot": robot_to_dict(lab.nominal_robot),
        "robot_errors": errors,
        "marker": lab.marker.to_dict(),
        "training": training_info,
        "checkerboard": board_entries,
        "poses": pose_entries,
    }
    atomic_write_json(tmp / "truth.json", truth)
    res.truth_path = out / "truth.json"
    res.truth = truth
    res.board_poses = np.array(board_poses).reshape(-1, 4, 4)
    res.joints = Q
    res.marker_positions = markers
    step("truth.json")
    return res

