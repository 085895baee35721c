"""How well the accepted checkerboard views cover the images: ROS camera_calibration's measures.

Each view gets X, Y (board centre, shrunk by half the board size, in [0, 1]), size (sqrt of the
board area over the image area) and skew (2·|90° − corner angle| in rad, clipped to 1)
(`view_params`). A bar is the spread of that measure over the accepted views divided by ROS's
ranges (0.7, 0.7, 0.4, 0.5); size and skew are counted from 0 (small or unskewed views are not
rewarded), X and Y from their minimum. For a pair the lower of the two cameras counts
(`coverage`).

"Enough views" rule (`Coverage.enough`): at least `MIN_GOOD_PAIRS` (10) accepted pairs and
every bar >= `MIN_BAR` (0.6) — or at least `MANY_PAIRS` (40) accepted pairs whatever the
bars (as ROS). The calibration itself runs from `MIN_PAIRS_TO_CALIBRATE` (6) pairs on and
reports the coverage shortfall as a warning.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Sequence

import numpy as np

from core.stereo.board import Board
from core.stereo.detection import PairDetection


PARAM_NAMES = ("X", "Y", "size", "skew")
PARAM_RANGES = (0.7, 0.7, 0.4, 0.5)       # ROS camera_calibration
MIN_GOOD_PAIRS = 10
MIN_BAR = 0.6
MANY_PAIRS = 40
MIN_PAIRS_TO_CALIBRATE = 6


@dataclass
class Coverage:
    """ROS-style coverage bars in [0, 1] (X, Y, size, skew) and the enough-views verdict."""

    x: float = 0.0
    y: float = 0.0
    size: float = 0.0
    skew: float = 0.0
    pairs: int = 0
    left: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 0.0)
    right: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 0.0)
    ranges: tuple[tuple[float, float], ...] = ()      # (lo, hi) per measure, both cameras
    enough: bool = False
    advice: list[str] = field(default_factory=list)

    @property
    def bars(self) -> dict[str, float]:
        return {"X": self.x, "Y": self.y, "size": self.size, "skew": self.skew}

    def to_dict(self) -> dict:
        return {**self.bars, "pairs": self.pairs, "enough": self.enough, "advice": list(self.advice)}


def view_params(corners: np.ndarray, board: Board, image_size: tuple[int, int]) -> np.ndarray:
    """ROS camera_calibration's (X, Y, size, skew) of one view, each in [0, 1]."""
    c = np.asarray(corners, dtype=np.float64).reshape(-1, 2)
    w, h = image_size
    cols = board.cols
    up_left, up_right, down_right, down_left = c[0], c[cols - 1], c[-1], c[-cols]
    a = up_right - up_left
    b = down_right - up_right
    d = down_left - down_right
    p, q = b + d, a + b
    area = abs(p[0] * q[1] - p[1] * q[0]) / 2.0
    border = math.sqrt(area)
    px = min(1.0, max(0.0, (c[:, 0].mean() - border / 2) / (w - border)))
    py = min(1.0, max(0.0, (c[:, 1].mean() - border / 2) / (h - border)))
    size = math.sqrt(area / (w * h))
    ab, cb = up_left - up_right, down_right - up_right
    cosang = float(ab @ cb / (np.linalg.norm(ab) * np.linalg.norm(cb)))
    angle = math.acos(min(1.0, max(-1.0, cosang)))
    skew = min(1.0, 2.0 * abs(math.pi / 2 - angle))
    return np.array([px, py, size, skew])


def param_distance(p: np.ndarray, q: np.ndarray) -> float:
    """ROS's L1 distance between two views' (X, Y, size, skew)."""
    return float(np.abs(np.asarray(p) - np.asarray(q)).sum())


def coverage(pairs: Sequence[PairDetection]) -> Coverage:
    """Coverage bars of the accepted pairs (see the module notes for the rule)."""
    good = [p for p in pairs if p.accepted and p.params_left is not None and p.params_right is not None]
    cov = Coverage(pairs=len(good))
    if not good:
        cov.advice = ["add pairs with the whole board visible in both images"]
        return cov
    bars, ranges = [], []
    for side in ("params_left", "params_right"):
        P = np.array([getattr(p, side) for p in good])
        lo = np.array([P[:, 0].min(), P[:, 1].min(), 0.0, 0.0])
        hi = P.max(axis=0)
        bars.append(tuple(float(min((h - l) / r, 1.0)) for l, h, r in zip(lo, hi, PARAM_RANGES)))
        ranges.append((lo, hi))
    cov.left, cov.right = bars
    both = np.minimum(np.array(bars[0]), np.array(bars[1]))
    cov.x, cov.y, cov.size, cov.skew = (float(v) for v in both)
    lo = np.minimum(ranges[0][0], ranges[1][0])
    hi = np.maximum(ranges[0][1], ranges[1][1])
    cov.ranges = tuple((float(a), float(b)) for a, b in zip(lo, hi))
    cov.enough = (len(good) >= MANY_PAIRS) or (len(good) >= MIN_GOOD_PAIRS and float(both.min()) >= MIN_BAR)
    advice = []
    if len(good) < MIN_GOOD_PAIRS:
        advice.append(f"add pairs: {len(good)} accepted, at least {MIN_GOOD_PAIRS} needed")
    hints = {"X": "move the board towards the left and right edges of the images",
             "Y": "move the board towards the top and bottom edges of the images",
             "size": "bring the board closer so that it fills more of the images",
             "skew": "tilt the board (about 30-45°) towards and away from the cameras"}
    for name, value in zip(PARAM_NAMES, both):
        if value < MIN_BAR and len(good) < MANY_PAIRS:
            advice.append(f"{name} coverage {value:.2f} < {MIN_BAR}: {hints[name]}")
    cov.advice = advice
    return cov
