"""Checkerboard corners in one image, and what was found in a pair (`PairDetection`).

Detection (`detect_corners`): `cv2.findChessboardCornersSB` on the image reduced by an
integer factor so that its long side is at most `BoardDetectionOptions.detect_max_side` px
(speed: ~20 ms instead of ~110 ms for 1280x1024), then `cv2.cornerSubPix` at full
resolution with a window of 0.35 x the smallest corner spacing. Measured on the real
640x512 pairs (`../shared/data/stereo-checkerboard-640x512`): the sector-based detector
alone gives a stereo RMS of 0.19 px and focal lengths 1.2 % above the reference, with the
sub-pixel refinement 0.163 px and 0.1 %. `CALIB_CB_NORMALIZE_IMAGE` loses 35 of those
50 dark images, so the first attempt uses no flag; then `EXHAUSTIVE | NORMALIZE_IMAGE`,
then the classic `findChessboardCorners` (+ `cornerSubPix`) as the fallback. The corners come
out in the canonical order of core.stereo.corner_order; an image whose corners touch the
border or whose edges are blurred is not ok, with a reason for the user.

`board_in_view`: the live preview's quick yes/no on a reduced frame.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

from core.images import to_gray8
from core.stereo.board import Board
from core.stereo.corner_order import canonical_order


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
