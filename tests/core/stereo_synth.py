"""Synthetic stereo calibration data for the tests: a known rig, board poses, exact corners.

Also the path of the real checkerboard pairs (`REAL_DATA`, skip when absent).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from core.stereo.board import Board
from core.camera import CameraModel
from core.stereo.rig import StereoRig
from core.transforms import rot_x, rot_y, rot_z

PROJECT_ROOT = Path(__file__).resolve().parents[2]
REAL_DATA = PROJECT_ROOT.parent / "shared" / "data" / "stereo-checkerboard-640x512"
REAL_REFERENCE_FOCAL = 518.05
SIZE = (1280, 1024)
BOARD = Board(9, 6, 25.0)


def real_pairs(numbers=range(1, 26)) -> list[tuple[Path, Path]]:
    return [(REAL_DATA / f"left{n:02d}.jpg", REAL_DATA / f"right{n:02d}.jpg") for n in numbers]


def true_rig() -> StereoRig:
    left = CameraModel([[1500.0, 0, 645.0], [0, 1501.0, 508.0], [0, 0, 1]], [-0.09, 0.06, 4e-4, -2e-4, 0.0], *SIZE)
    right = CameraModel([[1493.0, 0, 634.0], [0, 1494.5, 516.0], [0, 0, 1]], [-0.085, 0.05, -3e-4, 1e-4, 0.0],
                        *SIZE)
    R = rot_y(np.deg2rad(0.4)) @ rot_x(np.deg2rad(-0.25)) @ rot_z(np.deg2rad(0.15))
    return StereoRig(left, right, R, [-130.0, 0.9, 1.2])


def board_poses(n: int, rng: np.random.Generator, rig: StereoRig, board: Board = BOARD,
                margin: float = 20.0) -> list[tuple[np.ndarray, np.ndarray]]:
    """n poses (R, t: X_left = R·X_board + t) with the whole board inside both images."""
    mid = np.array([(board.cols - 1) * board.square / 2, (board.rows - 1) * board.square / 2, 0.0])
    obj = board.object_points().astype(float)
    out = []
    while len(out) < n:
        depth = rng.uniform(500.0, 1000.0)
        centre = np.array([rng.uniform(-0.3, 0.3) * depth + 65.0, rng.uniform(-0.25, 0.25) * depth, depth])
        R = rot_z(rng.uniform(-0.4, 0.4)) @ rot_y(rng.uniform(-0.8, 0.8)) @ rot_x(rng.uniform(-0.8, 0.8))
        t = centre - R @ mid
        P = obj @ R.T + t
        ul, ur = rig.project(P)
        if rig.left.in_image(ul, margin).all() and rig.right.in_image(ur, margin).all():
            out.append((R, t))
    return out


def synthetic_views(n: int = 14, noise: float = 0.05, seed: int = 1, rig: StereoRig | None = None,
                    board: Board = BOARD):
    """(rig, left corner lists, right corner lists) with Gaussian pixel noise."""
    rng = np.random.default_rng(seed)
    rig = rig or true_rig()
    obj = board.object_points().astype(float)
    left, right = [], []
    for R, t in board_poses(n, rng, rig, board):
        ul, ur = rig.project(obj @ R.T + t)
        left.append(ul + rng.normal(0, noise, ul.shape))
        right.append(ur + rng.normal(0, noise, ur.shape))
    return rig, left, right


def rotation_error_deg(A: np.ndarray, B: np.ndarray) -> float:
    c = (np.trace(A @ B.T) - 1.0) / 2.0
    return float(np.degrees(np.arccos(np.clip(c, -1.0, 1.0))))
