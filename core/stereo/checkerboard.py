"""Checkerboard detection for stereo calibration: corners, per-pair acceptance, coverage
(the image files are listed and paired by core.stereo.image_files).

Detection of one image: core.stereo.detection.
Corner order: core.stereo.corner_order; a pair whose row and column directions disagree between
the two images by more than 60° is rejected with a reason.

Coverage (`coverage`): ROS camera_calibration's measures. Each view gets
X, Y (board centre, shrunk by half the board size, in [0, 1]), size (sqrt of the board
area over the image area) and skew (2·|90° − corner angle| in rad, clipped to 1). A bar is
the spread of that measure over the accepted views divided by ROS's ranges
(0.7, 0.7, 0.4, 0.5); size and skew are counted from 0 (small or unskewed views are not
rewarded), X and Y from their minimum. For a pair the lower of the two cameras counts.

"Enough views" rule (`Coverage.enough`): at least `MIN_GOOD_PAIRS` (10) accepted pairs and
every bar >= `MIN_BAR` (0.6) — or at least `MANY_PAIRS` (40) accepted pairs whatever the
bars (as ROS). The calibration itself runs from `MIN_PAIRS_TO_CALIBRATE` (6) pairs on and
reports the coverage shortfall as a warning.

Similar views: ROS drops a live frame whose parameters are within L1 distance 0.2 of an
accepted one; for files the user chose, `min_param_distance` defaults to 0.05 (only
near-duplicates, which add weight but no information; on the real data set the closest two
pairs are 0.16 apart, and 0.2 would drop 4 of 25 good pairs).
"""
from __future__ import annotations

import math
import os
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path
from typing import Sequence

import numpy as np

from core.stereo.board import Board
from core.stereo.corner_order import match_order
from core.stereo.detection import BoardDetectionOptions, Detection, PairDetection, detect_corners
from core.images import load_gray, to_gray8
from core.stereo.image_files import pair_images
from core.task import Monitor


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


@dataclass
class DetectionResult:
    """All pairs of a data set, in file order, with the accepted ones and the coverage."""

    board: Board
    pairs: list[PairDetection]
    image_size: tuple[int, int] | None
    coverage: Coverage
    ignored_files: list[str] = field(default_factory=list)   # non-image files in the folders

    @property
    def accepted(self) -> list[PairDetection]:
        return [p for p in self.pairs if p.accepted]

    @property
    def rejected(self) -> list[PairDetection]:
        return [p for p in self.pairs if not p.accepted]


# --------------------------------------------------------------------------- view parameters


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


# --------------------------------------------------------------------------- pairs


def detect_pair(left, right, board: Board, options: BoardDetectionOptions = BoardDetectionOptions(), *,
                index: int = 0, name: str | None = None) -> PairDetection:
    """Detect and check one pair. `left`/`right` are image paths or arrays.

    Acceptance (in this order): both images readable, same size, board found in both,
    not at the border, not blurred, corner order consistent between the two images.
    (Similarity to other pairs and the common image size are checked by `detect_pairs`.)
    """
    lp = str(left) if isinstance(left, (str, Path)) else "left"
    rp = str(right) if isinstance(right, (str, Path)) else "right"
    if name is None:
        name = f"{Path(lp).name} | {Path(rp).name}"
    dets = []
    for src, label in ((left, lp), (right, rp)):
        if isinstance(src, (str, Path)):
            gray, why = load_gray(src)
        else:
            gray, why = (to_gray8(src), None) if src is not None else (None, "no image")
        if gray is None:
            dets.append(Detection(False, None, None, why))
        else:
            dets.append(detect_corners(gray, board, options))
    dl, dr = dets
    pair = PairDetection(index, name, lp, rp, dl, dr)
    ln, rn = Path(lp).name, Path(rp).name
    if dl.image_size is None or dr.image_size is None:
        bad = [f"{n}: {d.reason}" for n, d in ((ln, dl), (rn, dr)) if d.image_size is None]
        pair.reason = "; ".join(bad)
        return _verdict(pair)
    if dl.image_size != dr.image_size:
        pair.reason = (f"left/right image size mismatch: {ln} is {dl.image_size[0]}x{dl.image_size[1]}, "
                       f"{rn} is {dr.image_size[0]}x{dr.image_size[1]}")
        return _verdict(pair)
    if not dl.ok or not dr.ok:
        bad = [f"{n}: {d.reason}" for n, d in ((ln, dl), (rn, dr)) if not d.ok]
        pair.reason = "; ".join(bad)
        return _verdict(pair)
    fixed, sym, score = match_order(dl.corners, dr.corners, board)
    if score < 1.0:
        pair.reason = ("the board appears turned by more than 60° between the left and right images; "
                       "cannot match the corners")
        return _verdict(pair)
    dr.corners, pair.reordered = fixed, sym
    pair.params_left = view_params(dl.corners, board, dl.image_size)
    pair.params_right = view_params(dr.corners, board, dr.image_size)
    pair.accepted = True
    return _verdict(pair)


def _verdict(pair: PairDetection) -> PairDetection:
    pair.detected_ok, pair.detected_reason = pair.accepted, pair.reason
    return pair


def detect_pairs(pairs: Sequence[tuple], board: Board, options: BoardDetectionOptions = BoardDetectionOptions(), *,
                 names: Sequence[str] | None = None, ignored_files: Sequence[str] = (),
                 progress=None, cancelled=None) -> DetectionResult:
    """Detect every pair (paths or arrays), then check sizes and similarity across pairs.

    Pairs are processed in order; a pair too similar to an earlier accepted one is
    rejected. The common image size is the most frequent size among readable pairs.
    """
    monitor = Monitor(progress, cancelled)
    n = len(pairs)
    monitor.step(0.0, f"detecting the board in {n} pairs")
    results: list[PairDetection | None] = [None] * n

    def work(i):
        left, right = pairs[i]
        name = names[i] if names is not None else None
        return detect_pair(left, right, board, options, index=i, name=name)

    workers = max(1, min(int(options.workers), n, os.cpu_count() or 1))
    if workers == 1:
        for i in range(n):
            monitor.check()
            results[i] = work(i)
            monitor.step((i + 1) / max(n, 1), f"pair {i + 1} of {n}")
    else:
        with ThreadPoolExecutor(max_workers=workers) as pool:
            futures = [pool.submit(work, i) for i in range(n)]
            try:
                for i, fut in enumerate(futures):
                    results[i] = fut.result()
                    monitor.step((i + 1) / max(n, 1), f"pair {i + 1} of {n}")
            except BaseException:
                for fut in futures:
                    fut.cancel()
                raise
    return screen_pairs([p for p in results if p is not None], board, options, ignored_files=ignored_files)


def screen_pairs(pairs: Sequence[PairDetection], board: Board, options: BoardDetectionOptions = BoardDetectionOptions(),
                 *, ignored_files: Sequence[str] = ()) -> DetectionResult:
    """The checks across pairs, redone from each pair's own verdict (`detect_pair`).

    For a page that adds or removes pairs one at a time: pairs are renumbered in list
    order, the common image size is the most frequent one, and a pair too similar to an
    earlier accepted one is rejected. Returns the DetectionResult with its coverage.
    """
    found = list(pairs)
    for i, p in enumerate(found):
        p.index = i
        p.accepted, p.reason = p.detected_ok, p.detected_reason
    sizes = [p.left.image_size for p in found
             if p.left.image_size is not None and p.left.image_size == p.right.image_size]
    image_size = max(set(sizes), key=lambda s: (sizes.count(s), -sizes.index(s))) if sizes else None
    kept: list[PairDetection] = []
    for p in found:
        if not p.accepted:
            continue
        if p.image_size != image_size:
            p.accepted = False
            p.reason = (f"image size {p.image_size[0]}x{p.image_size[1]} differs from the other pairs' "
                        f"{image_size[0]}x{image_size[1]}")
            continue
        for q in kept:
            d = max(param_distance(p.params_left, q.params_left), param_distance(p.params_right, q.params_right))
            if d <= options.min_param_distance:
                p.accepted = False
                p.reason = (f"too similar to pair {q.index + 1} ({q.name}): view distance {d:.3f} "
                            f"<= {options.min_param_distance}")
                break
        if p.accepted:
            kept.append(p)
    return DetectionResult(board, found, image_size, coverage(found), list(ignored_files))


def detect_folders(left, right, board: Board, options: BoardDetectionOptions = BoardDetectionOptions(), *,
                   progress=None, cancelled=None) -> DetectionResult:
    """Pair the images of two folders (or patterns, or file lists) by sorted name and detect."""
    pairs, ignored = pair_images(left, right)
    return detect_pairs(pairs, board, options, ignored_files=ignored, progress=progress, cancelled=cancelled)


def summarize_rejections(pairs: Sequence[PairDetection], limit: int = 6) -> str:
    """One line grouping the rejected pairs' problems: 'reason [files]; reason [files]'.

    Problems of single images (unreadable, board not found, blurred, ...) are grouped by
    reason with the image names; problems of a pair (size mismatch, too similar, ...) with
    the pair names.
    """
    groups: dict[str, list[str]] = {}
    for p in pairs:
        if p.accepted:
            continue
        image_level = False
        for det, path in ((p.left, p.left_path), (p.right, p.right_path)):
            if not det.ok and det.reason:
                groups.setdefault(det.reason, []).append(Path(path).name)
                image_level = True
        if not image_level:
            groups.setdefault(p.reason or "rejected", []).append(p.name)
    parts = []
    for reason, names in groups.items():
        shown = ", ".join(names[:limit]) + (f", ... ({len(names)} in all)" if len(names) > limit else "")
        parts.append(f"{reason} [{shown}]")
    return "; ".join(parts)
