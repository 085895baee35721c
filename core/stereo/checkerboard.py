"""Checkerboard detection for stereo calibration: corners, per-pair acceptance, coverage
(the image files are listed and paired by core.stereo.image_files).

Detection (`detect_corners`): `cv2.findChessboardCornersSB` on the image reduced by an
integer factor so that its long side is at most `BoardDetectionOptions.detect_max_side` px
(speed: ~20 ms instead of ~110 ms for 1280x1024), then `cv2.cornerSubPix` at full
resolution with a window of 0.35 x the smallest corner spacing. Measured on the real
640x512 pairs (`../shared/data/stereo-checkerboard-640x512`): the sector-based detector
alone gives a stereo RMS of 0.19 px and focal lengths 1.2 % above the reference, with the
sub-pixel refinement 0.163 px and 0.1 %. `CALIB_CB_NORMALIZE_IMAGE` loses 35 of those
50 dark images, so the first attempt uses no flag; then `EXHAUSTIVE | NORMALIZE_IMAGE`,
then the classic `findChessboardCorners` (+ `cornerSubPix`) as the fallback.

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

import cv2
import numpy as np

from core.stereo.board import Board
from core.stereo.corner_order import canonical_order, match_order
from core.images import load_gray, to_gray8
from core.stereo.image_files import pair_images
from core.task import Monitor


PARAM_NAMES = ("X", "Y", "size", "skew")
PARAM_RANGES = (0.7, 0.7, 0.4, 0.5)       # ROS camera_calibration
MIN_GOOD_PAIRS = 10
MIN_BAR = 0.6
MANY_PAIRS = 40
MIN_PAIRS_TO_CALIBRATE = 6

_SUBPIX_CRITERIA = (cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_COUNT, 50, 1e-3)


@dataclass(frozen=True)
class BoardDetectionOptions:
    detect_max_side: int = 960          # detect on the image reduced to at most this long side
    subpix_fraction: float = 0.35       # cornerSubPix half-window / smallest corner spacing
    border_px: float = 4.0              # corners closer to the image edge: board partly outside
    blur_fraction: float = 0.3          # blurred if the edge width (px) > this x square size (px) ...
    blur_min_px: float = 4.0            # ... and > this many px
    min_param_distance: float = 0.05    # ROS-style L1 distance under which a pair is "too similar"
    workers: int = 2                    # detection threads (OpenCV releases the GIL)


@dataclass
class Detection:
    """One image's checkerboard detection. `corners` is (N, 2) float32 px in the board order."""

    ok: bool
    corners: np.ndarray | None = None
    image_size: tuple[int, int] | None = None   # (width, height), None when unreadable
    reason: str | None = None                   # why not ok (or why rejected), for the user
    method: str = ""                             # "sb", "classic", "sb-full" or "sb-exhaustive"
    sharpness_px: float | None = None            # edge width (10-90 %), estimateChessboardSharpness
    square_px: float | None = None               # smallest corner spacing, px
    found_grid: tuple[int, int] | None = None    # (cols, rows) grid seen when the board was not found


@dataclass
class PairDetection:
    """A left/right pair: both detections, acceptance, ROS view parameters (drawable)."""

    index: int
    name: str                         # "left01.jpg | right01.jpg"
    left_path: str
    right_path: str
    left: Detection
    right: Detection
    accepted: bool = False
    reason: str | None = None         # why the pair is rejected
    reordered: str = ""               # symmetry applied to the right corners ("" = none)
    params_left: np.ndarray | None = None    # (X, Y, size, skew)
    params_right: np.ndarray | None = None
    detected_ok: bool = False         # the pair's own verdict, before the checks across pairs
    detected_reason: str | None = None

    @property
    def image_size(self) -> tuple[int, int] | None:
        return self.left.image_size


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


# --------------------------------------------------------------------------- detection


PREVIEW_CHECK_WIDTH = 640       # px: the live preview's board check works on frames this wide


def board_in_view(image: np.ndarray, board: Board, *, width: int = PREVIEW_CHECK_WIDTH) -> bool:
    """True when the whole board seems in `image` (any OpenCV image): a quick yes/no for a live
    preview, on the grey image shrunk to at most `width` px, with `CALIB_CB_FAST_CHECK` (a frame
    without a board is rejected in a few ms). A captured pair is still detected at full
    resolution (`detect_pair`)."""
    gray = to_gray8(image)
    h, w = gray.shape[:2]
    if w > width:
        gray = cv2.resize(gray, (int(width), max(1, round(h * width / w))), interpolation=cv2.INTER_AREA)
    flags = cv2.CALIB_CB_ADAPTIVE_THRESH | cv2.CALIB_CB_NORMALIZE_IMAGE | cv2.CALIB_CB_FAST_CHECK
    found, _ = cv2.findChessboardCorners(gray, board.pattern_size, flags=flags)
    return bool(found)


def detect_corners(gray: np.ndarray, board: Board, options: BoardDetectionOptions = BoardDetectionOptions()
                   ) -> Detection:
    """Find the board's inner corners in one 8-bit image (see the module notes)."""
    gray = to_gray8(gray)
    h, w = gray.shape[:2]
    size = (int(w), int(h))
    pattern = board.pattern_size
    factor = max(1, int(math.ceil(max(w, h) / float(options.detect_max_side))))
    small = cv2.resize(gray, (w // factor, h // factor), interpolation=cv2.INTER_AREA) if factor > 1 else gray
    classic = cv2.CALIB_CB_ADAPTIVE_THRESH | cv2.CALIB_CB_NORMALIZE_IMAGE | cv2.CALIB_CB_FAST_CHECK
    # Cheapest first: SB on the reduced image (~20 ms at 640x512). When it fails, one probe
    # for any visible corner grid (~40 ms) tells a board larger than the one given (wrong
    # board size) at once, instead of ~200 ms per further attempt. Then the classic detector on the reduced
    # image (~3 ms; finds strongly tilted boards whose squares got too small for SB), SB at
    # full resolution, and SB's exhaustive search.
    # Each raw detection is refined at full resolution and checked against the grid (see
    # `_refine`); if one corner is off (seen: SB on a reduced image put one corner 6.7 px
    # off), the next attempt is tried.
    grid, probed, unreliable = None, False, None
    attempts = [("sb", 0, small, factor), ("probe", 0, small, factor), ("classic", classic, small, factor)]
    if factor > 1:
        attempts.append(("sb-full", 0, gray, 1))
    attempts.append(("sb-exhaustive", cv2.CALIB_CB_EXHAUSTIVE | cv2.CALIB_CB_NORMALIZE_IMAGE, small, factor))
    refined = None
    for name, flags, img, f in attempts:
        if name == "probe":
            grid, c = _visible_grid(img, board)
            probed = True
            if grid is None:
                continue
            if c is None:
                # a grid larger than the board: the board size is wrong, no detector will
                # find it; a smaller one may be the probe missing a foreshortened column
                if unreliable is None and _larger_grid(grid, board):
                    return Detection(False, None, size, _not_found_reason(board, grid), found_grid=grid)
                continue
            raw, method = c, "sb"
        else:
            try:
                if name.startswith("sb"):
                    found, c = cv2.findChessboardCornersSB(img, pattern, flags=flags)
                else:
                    found, c = cv2.findChessboardCorners(img, pattern, flags=flags)
            except cv2.error:
                found, c = False, None
            if not (found and c is not None and len(c) == board.corner_count):
                continue
            raw, method = c.reshape(-1, 2).astype(np.float64), name
        refined, moved = _refine(gray, raw, f, board, options)
        if refined is not None:
            break
        unreliable = moved
    if refined is None:
        if unreliable is not None:
            return Detection(False, None, size, f"corners not reliable: a corner is {unreliable:.1f} px off "
                                                f"the grid of its neighbours")
        if not probed:
            grid, _ = _visible_grid(small, board)
        return Detection(False, None, size, _not_found_reason(board, grid), found_grid=grid)
    corners = canonical_order(refined.astype(np.float32), board)
    det = Detection(True, corners, size, None, method, square_px=float(_min_spacing(corners, board)))
    try:
        sharp, _ = cv2.estimateChessboardSharpness(gray, pattern, corners.reshape(-1, 1, 2))
        det.sharpness_px = float(sharp[0])
    except cv2.error:
        det.sharpness_px = None
    m = options.border_px
    if np.any((corners[:, 0] < m - 0.5) | (corners[:, 1] < m - 0.5)
              | (corners[:, 0] > w - 0.5 - m) | (corners[:, 1] > h - 0.5 - m)):
        det.ok, det.reason = False, "partial board: corners touch the image border"
    elif det.sharpness_px is not None and det.sharpness_px > options.blur_min_px \
            and det.sharpness_px > options.blur_fraction * det.square_px:
        det.ok = False
        det.reason = (f"blurred: edges {det.sharpness_px:.1f} px wide for {det.square_px:.0f} px squares "
                      f"(limit {max(options.blur_min_px, options.blur_fraction * det.square_px):.1f} px)")
    return det


def _refine(gray: np.ndarray, raw: np.ndarray, scale: int, board: Board, options: BoardDetectionOptions
            ) -> tuple[np.ndarray | None, float]:
    """cornerSubPix at full resolution of corners found at 1/scale, then the grid check.

    Returns (corners, worst grid deviation px), corners None when a corner does not sit where
    its eight neighbours put it (`grid_deviation` > max(1.5 px, 0.12 x square size); on the
    real and rendered pairs good detections stay below 0.035 x square size).
    """
    corners = (raw + 0.5) * scale - 0.5 if scale > 1 else raw
    spacing = _min_spacing(corners, board)
    half = int(min(max(round(options.subpix_fraction * spacing), 2), 25))
    refined = cv2.cornerSubPix(gray, corners.astype(np.float32).reshape(-1, 1, 2), (half, half), (-1, -1),
                               _SUBPIX_CRITERIA).reshape(-1, 2)
    if not np.all(np.isfinite(refined)):
        return None, float("inf")
    worst = float(grid_deviation(refined, board).max())
    if worst > max(1.5, 0.12 * _min_spacing(refined, board)):
        return None, worst
    return refined, worst


def grid_deviation(corners: np.ndarray, board: Board) -> np.ndarray:
    """(rows, cols) px distance of each corner from where a homography through its 8
    neighbours (a 3x3 block, shifted inwards at the edges) puts it: a mis-located corner
    stands out, lens distortion over two squares does not."""
    rows, cols = board.rows, board.cols
    g = np.asarray(corners, dtype=np.float64).reshape(rows, cols, 2)
    if rows < 3 or cols < 3:
        return np.zeros((rows, cols))
    ii, jj = np.meshgrid(np.arange(rows), np.arange(cols), indexing="ij")
    i0 = np.clip(ii - 1, 0, rows - 3).ravel()
    j0 = np.clip(jj - 1, 0, cols - 3).ravel()
    di, dj = np.meshgrid(np.arange(3), np.arange(3), indexing="ij")
    bi = i0[:, None] + di.ravel()[None]            # (n, 9) block rows
    bj = j0[:, None] + dj.ravel()[None]
    centre = (bi == ii.ravel()[:, None]) & (bj == jj.ravel()[:, None])
    keep = ~centre
    n = rows * cols
    src_i = bi[keep].reshape(n, 8).astype(np.float64)
    src_j = bj[keep].reshape(n, 8).astype(np.float64)
    dst = g[bi[keep], bj[keep]].reshape(n, 8, 2)
    mean = dst.mean(axis=1, keepdims=True)
    scale = np.sqrt(((dst - mean) ** 2).sum(axis=2).mean(axis=1))[:, None, None] + 1e-12
    d = (dst - mean) / scale
    x = src_j - j0[:, None]
    y = src_i - i0[:, None]
    one, zero = np.ones_like(x), np.zeros_like(x)
    u, v = d[..., 0], d[..., 1]
    A = np.concatenate([
        np.stack([x, y, one, zero, zero, zero, -u * x, -u * y, -u], axis=2),
        np.stack([zero, zero, zero, x, y, one, -v * x, -v * y, -v], axis=2)], axis=1)   # (n, 16, 9)
    _, _, vt = np.linalg.svd(A)
    H = vt[:, -1, :].reshape(n, 3, 3)
    p = np.stack([jj.ravel() - j0, ii.ravel() - i0, np.ones(n)], axis=1)
    q = np.einsum("nij,nj->ni", H, p)
    pred = q[:, :2] / q[:, 2:3] * scale[:, 0] + mean[:, 0]
    return np.linalg.norm(pred - g.reshape(n, 2), axis=1).reshape(rows, cols)


def _visible_grid(gray: np.ndarray, board: Board) -> tuple[tuple[int, int] | None, np.ndarray | None]:
    """(cols, rows) of whatever checkerboard grid is visible (or None), and its corners in
    the board's (cols, rows) layout when the grid is the board itself (else None)."""
    try:
        found, c, meta = cv2.findChessboardCornersSBWithMeta(gray, (3, 3), cv2.CALIB_CB_LARGER)
    except cv2.error:
        return None, None
    if not found or meta is None or c is None:
        return None, None
    rows, cols = meta.shape[:2]
    if len(c) != rows * cols:
        return (int(cols), int(rows)), None
    g = np.asarray(c, dtype=np.float64).reshape(rows, cols, 2)
    if (cols, rows) == (board.cols, board.rows):
        return (int(cols), int(rows)), g.reshape(-1, 2)
    if (rows, cols) == (board.cols, board.rows):
        return (int(cols), int(rows)), g.transpose(1, 0, 2).reshape(-1, 2)
    return (int(cols), int(rows)), None


def _larger_grid(grid: tuple[int, int], board: Board) -> bool:
    a, b = sorted(grid)
    lo, hi = sorted((board.cols, board.rows))
    return a >= lo and b >= hi and (a, b) != (lo, hi)


def _not_found_reason(board: Board, grid: tuple[int, int] | None) -> str:
    want = f"{board.cols}x{board.rows}"
    if grid is None:
        return f"board not found (looked for {want} inner corners)"
    a, b = sorted(grid)
    lo, hi = sorted((board.cols, board.rows))
    if _larger_grid(grid, board):
        return (f"board not found: a {max(grid)}x{min(grid)} corner grid is visible, not {want} "
                f"(check the board size: it counts inner corners)")
    if a <= lo and b <= hi:
        return (f"partial board: only {max(grid)}x{min(grid)} of the {want} inner corners are visible "
                f"(board partly outside the image or hidden, or check the board size)")
    return f"board not found: a {max(grid)}x{min(grid)} corner grid is visible, not {want} (check the board size)"


def _min_spacing(corners: np.ndarray, board: Board) -> float:
    g = np.asarray(corners, dtype=np.float64).reshape(board.rows, board.cols, 2)
    along = np.linalg.norm(np.diff(g, axis=1), axis=2).min()
    across = np.linalg.norm(np.diff(g, axis=0), axis=2).min()
    return float(min(along, across))


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
