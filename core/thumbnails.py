"""Pictures of a stereo pair for a thumbnail strip: left | right, each reduced to a width in
pixels (aspect kept), with what was found drawn on it: the checkerboard corners
(`compose_pair_thumbnail`) or the marker outlines and reference points (`marker_pair_thumbnail`).
Plain numpy/OpenCV, row-major RGB uint8 out: made by the jobs on a worker thread, shown by
widgets.thumbnail_strip."""
from __future__ import annotations

import cv2
import numpy as np


def _board_side(gray: np.ndarray | None, corners: np.ndarray | None, pattern_size: tuple[int, int],
                found: bool, width: int, height: int) -> np.ndarray:
    if gray is None:
        out = np.full((height, width, 3), 235, np.uint8)
        cv2.line(out, (0, 0), (width - 1, height - 1), (200, 200, 200), 1, cv2.LINE_AA)
        cv2.line(out, (0, height - 1), (width - 1, 0), (200, 200, 200), 1, cv2.LINE_AA)
        return out
    img = gray if gray.ndim == 2 else cv2.cvtColor(gray, cv2.COLOR_BGR2GRAY)
    h, w = img.shape[:2]
    scale = min(width / w, height / h)
    # draw at 3x the thumbnail size, then reduce: OpenCV's corner circles and lines become fine
    big = 3.0 * scale if 3.0 * scale < 1.0 else 1.0
    bw, bh = max(1, int(round(w * big))), max(1, int(round(h * big)))
    work = cv2.resize(img, (bw, bh), interpolation=cv2.INTER_AREA) if big < 1.0 else img
    bgr = cv2.cvtColor(work, cv2.COLOR_GRAY2BGR)
    if corners is not None and len(corners):
        pts = (np.asarray(corners, np.float32).reshape(-1, 1, 2) * big).astype(np.float32)
        if found and len(pts) == pattern_size[0] * pattern_size[1]:
            cv2.drawChessboardCorners(bgr, pattern_size, pts, True)
        else:
            for x, y in pts.reshape(-1, 2):
                cv2.circle(bgr, (int(round(x)), int(round(y))), 4, (0, 0, 255), -1, cv2.LINE_AA)
    nw, nh = max(1, int(round(w * scale))), max(1, int(round(h * scale)))
    bgr = cv2.resize(bgr, (nw, nh), interpolation=cv2.INTER_AREA)
    out = np.full((height, width, 3), 235, np.uint8)
    y0, x0 = (height - nh) // 2, (width - nw) // 2
    out[y0:y0 + nh, x0:x0 + nw] = bgr
    return out


def compose_pair_thumbnail(left: np.ndarray | None, right: np.ndarray | None,
                           left_corners: np.ndarray | None = None, right_corners: np.ndarray | None = None,
                           pattern_size: tuple[int, int] = (9, 6), *, found: tuple[bool, bool] = (True, True),
                           width: int = 120, gap: int = 4) -> np.ndarray:
    """Left | right reduced to `width` px each (aspect kept), detected corners drawn
    (cv2.drawChessboardCorners when the whole grid was found, red dots otherwise).
    Returns a row-major RGB uint8 array. `left`/`right` are grey or BGR images or None."""
    ref = left if left is not None else right
    aspect = (ref.shape[0] / ref.shape[1]) if ref is not None else 0.8
    height = max(1, int(round(width * aspect)))
    a = _board_side(left, left_corners, pattern_size, found[0], width, height)
    b = _board_side(right, right_corners, pattern_size, found[1], width, height)
    sep = np.full((height, gap, 3), 255, np.uint8)
    bgr = np.concatenate([a, sep, b], axis=1)
    return np.ascontiguousarray(bgr[:, :, ::-1])


def _marker_side(gray, outline, reference, ok: bool, width: int, height: int) -> np.ndarray:
    if gray is None:
        return np.full((height, width, 3), 235, np.uint8)
    img = gray if gray.ndim == 2 else cv2.cvtColor(gray, cv2.COLOR_BGR2GRAY)
    h, w = img.shape[:2]
    scale = min(width / w, height / h)
    nw, nh = max(1, int(round(w * scale))), max(1, int(round(h * scale)))
    small = cv2.cvtColor(cv2.resize(img, (nw, nh), interpolation=cv2.INTER_AREA), cv2.COLOR_GRAY2BGR)
    colour = (83, 168, 52) if ok else (37, 48, 217)        # BGR of INLIER / OUTLIER
    if outline is not None:
        pts = np.round((np.asarray(outline, float).reshape(-1, 2) + 0.5) * scale - 0.5).astype(np.int32)
        cv2.polylines(small, [pts.reshape(-1, 1, 2)], True, colour, 1, cv2.LINE_AA)
    if reference is not None:
        x, y = ((np.asarray(reference, float).reshape(2) + 0.5) * scale - 0.5)
        r = max(6, int(0.03 * nw))
        cv2.line(small, (int(x - r), int(y)), (int(x + r), int(y)), (37, 48, 217), 1, cv2.LINE_AA)
        cv2.line(small, (int(x), int(y - r)), (int(x), int(y + r)), (37, 48, 217), 1, cv2.LINE_AA)
    out = np.full((height, width, 3), 235, np.uint8)
    y0, x0 = (height - nh) // 2, (width - nw) // 2
    out[y0:y0 + nh, x0:x0 + nw] = small
    return out


def marker_pair_thumbnail(left, right, left_outline=None, right_outline=None, left_reference=None,
                          right_reference=None, *, ok: bool = True, width: int = 320, gap: int = 4) -> np.ndarray:
    """Left | right reduced to `width` px each, with the marker outlines (green when located,
    red when not) and the reference points. Row-major RGB uint8."""
    ref = left if left is not None else right
    aspect = (ref.shape[0] / ref.shape[1]) if ref is not None else 0.8
    height = max(1, int(round(width * aspect)))
    a = _marker_side(left, left_outline, left_reference, ok, width, height)
    b = _marker_side(right, right_outline, right_reference, ok, width, height)
    sep = np.full((height, gap, 3), 255, np.uint8)
    return np.ascontiguousarray(np.concatenate([a, sep, b], axis=1)[:, :, ::-1])
