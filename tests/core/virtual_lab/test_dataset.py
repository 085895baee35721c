"""simulate_dataset: the files, their determinism, the ground truth, and clean failures."""
from __future__ import annotations

import csv
import json
from pathlib import Path

import cv2
import numpy as np
import pytest

from core.stereo.board import Board
from core.camera import CameraModel
from core.errors import Cancelled, RoboCalError, UsageError
from core.robot.file import robot_from_dict
from core.virtual_lab.dataset import simulate_dataset

SMALL = dict(pairs=2, poses=2)


def _files(folder: Path) -> dict[str, bytes]:
    return {str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    base = tmp_path_factory.mktemp("sim")
    a = simulate_dataset(base / "a", seed=5, **SMALL)
    b = simulate_dataset(base / "b", seed=5, **SMALL)
    c = simulate_dataset(base / "c", seed=6, **SMALL)
    return base, a, b, c


def test_layout(runs):
    base, a, _, _ = runs
    names = sorted(_files(base / "a"))
    assert names == sorted([
        "checkerboard/left/pair_000.png", "checkerboard/left/pair_001.png",
        "checkerboard/right/pair_000.png", "checkerboard/right/pair_001.png",
        "marker/training.png",
        "poses/left/pose_000.png", "poses/left/pose_001.png",
        "poses/right/pose_000.png", "poses/right/pose_001.png",
        "poses/joints.csv", "truth.json"])
    # No temporary folder is left beside the dataset.
    assert sorted(p.name for p in base.iterdir()) == ["a", "b", "c"]
    assert a.pairs == 2 and a.poses == 2 and a.truth_path == base / "a" / "truth.json"
    assert all(p.is_file() for p in a.checkerboard_left + a.checkerboard_right + a.pose_left + a.pose_right)
    for p in a.checkerboard_left + a.pose_right:
        img = cv2.imread(str(p), cv2.IMREAD_UNCHANGED)
        assert img.dtype == np.uint8 and img.shape == (1024, 1280)


def test_same_seed_same_bytes_other_seed_other_bytes(runs):
    base, _, _, _ = runs
    fa, fb, fc = _files(base / "a"), _files(base / "b"), _files(base / "c")
    assert fa == fb
    assert fa.keys() == fc.keys()
    assert all(fa[k] != fc[k] for k in fa)


def test_truth_is_consistent(runs):
    base, a, _, _ = runs
    truth = json.loads((base / "a" / "truth.json").read_text())
    st = truth["stereo"]
    for key in ("image_width", "image_height", "K1", "D1", "K2", "D2", "R", "T"):
        assert key in st
    assert (st["image_width"], st["image_height"]) == (1280, 1024)
    assert np.array(st["K1"]).shape == (3, 3) and np.array(st["R"]).shape == (3, 3) and len(st["T"]) == 3
    assert abs(np.linalg.norm(st["T"]) - 130) < 2
    board = Board(truth["board"]["cols"], truth["board"]["rows"], truth["board"]["square"])
    true = robot_from_dict(truth["robot"])
    nominal = robot_from_dict(truth["nominal_robot"])
    assert "marker" in true.targets and "marker" in nominal.targets
    assert truth["marker"]["outer_size"] == 40.0
    # Joints: csv and truth agree; marker positions are the true robot's target positions.
    with open(base / "a" / "poses" / "joints.csv", newline="") as fh:
        rows = list(csv.reader(fh))
    assert rows[0] == ["pose"] + [f"q{i}" for i in range(1, true.dof + 1)]
    assert len(rows) == 1 + len(truth["poses"]) == 3
    for row, entry in zip(rows[1:], truth["poses"]):
        q_deg = [float(v) for v in row[1:]]
        assert q_deg == entry["q"]
        q = true.q_from_file(q_deg)
        assert np.allclose(true.target_position(q, "marker"), entry["marker"], atol=1e-9)
        assert true.within_limits(q)
        assert 400 <= entry["marker"][2] <= 900
    # The nominal robot differs from the true one by millimetres, not more.
    q = true.q_from_file(truth["poses"][0]["q"])
    gap = np.linalg.norm(true.target_position(q, "marker") - nominal.target_position(q, "marker"))
    assert 0.5 < gap < 30
    # Checkerboard poses put the board inside both images.
    left = CameraModel(np.array(st["K1"]), np.array(st["D1"]))
    right = CameraModel(np.array(st["K2"]), np.array(st["D2"]))
    R, T = np.array(st["R"]), np.array(st["T"])
    assert len(truth["checkerboard"]) == 2
    for entry in truth["checkerboard"]:
        P = np.array(entry["pose"])
        X = board.object_points().astype(float) @ P[:3, :3].T + P[:3, 3]
        assert left.in_image(left.project(X)).all() and right.in_image(right.project(X @ R.T + T)).all()
        assert (base / "a" / entry["left"]).is_file() and (base / "a" / entry["right"]).is_file()
    assert truth["training"]["image"] == "marker/training.png"
    assert truth["seed"] == 5 and truth["noise"] == 0.5


def test_previous_dataset_is_replaced_and_foreign_folder_refused(tmp_path):
    out = tmp_path / "ds"
    simulate_dataset(out, seed=1, pairs=1, poses=0)
    (out / "stale.txt").write_text("old")
    simulate_dataset(out, seed=1, pairs=0, poses=1)
    names = sorted(_files(out))
    assert "stale.txt" not in names and "poses/left/pose_000.png" in names
    assert not any(n.startswith("checkerboard/left/pair") for n in names)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["ds"]
    foreign = tmp_path / "mine"
    foreign.mkdir()
    (foreign / "notes.txt").write_text("keep me")
    with pytest.raises(RoboCalError) as info:
        simulate_dataset(foreign, pairs=1, poses=1)
    assert str(foreign) in info.value.message
    assert (foreign / "notes.txt").read_text() == "keep me"


def test_cancel_leaves_nothing(tmp_path):
    calls = []

    def progress(fraction, message):
        calls.append((fraction, message))

    def cancelled():
        return len(calls) >= 3

    with pytest.raises(Cancelled):
        simulate_dataset(tmp_path / "ds", seed=0, pairs=3, poses=3, progress=progress, cancelled=cancelled)
    assert list(tmp_path.iterdir()) == []
    fractions = [f for f, _ in calls]
    assert fractions == sorted(fractions) and all(0.0 <= f <= 1.0 for f in fractions)


def test_bad_arguments(tmp_path):
    with pytest.raises(UsageError):
        simulate_dataset(tmp_path / "x", pairs=-1)
    with pytest.raises(UsageError):
        simulate_dataset(tmp_path / "x", noise=-0.1)
    blocker = tmp_path / "file"
    blocker.write_text("")
    with pytest.raises(RoboCalError) as info:
        simulate_dataset(blocker / "ds", pairs=1, poses=1)
    assert str(blocker / "ds") in info.value.message
    assert sorted(p.name for p in tmp_path.iterdir()) == ["file"]
