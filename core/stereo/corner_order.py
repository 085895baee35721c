"""The order of a checkerboard's corners, and the board's symmetries.

The left corners are put in a canonical order (`canonical_order`: board x along the image
x-ish, rows downwards, board z away from the camera), then the right corners are relabelled
with the board symmetry (180° for a non-square board, also 90° turns for a square one) whose
row and column directions agree best with the left image (`match_order`). A pair whose
directions disagree by more than 60° is rejected with a reason (core.stereo.screening). The
calibration checks the order once more against the stereo geometry of all pairs, which also
covers a camera mounted upside down, with `board_symmetries`. Corners are (N, 2) px, rows of
`board.cols` corners.
"""
from __future__ import annotations

from functools import lru_cache

import numpy as np

from core.stereo.board import Board


@lru_cache(maxsize=32)
def board_symmetries(cols: int, rows: int) -> tuple[tuple[str, np.ndarray, np.ndarray, np.ndarray], ...]:
    """Relabellings of the corner grid that map the board onto itself.

    Each is (name, perm, Rs, ts) with relabelled corners = corners[perm] and
    object_points[perm] = object_points @ Rs.T + ts (ts in units of one square), i.e. a
    proper rotation of the board frame. The mirror ones (flip of rows or columns) turn the
    board over (z towards the camera).
    """
    idx = np.arange(cols * rows).reshape(rows, cols)
    cands = [("", idx), ("rotated 180°", idx[::-1, ::-1]),
             ("rows reversed", idx[::-1, :]), ("columns reversed", idx[:, ::-1])]
    if cols == rows:
        cands += [("rotated 90°", np.rot90(idx, 1)), ("rotated 270°", np.rot90(idx, 3)),
                  ("transposed", idx.T), ("anti-transposed", idx[::-1, ::-1].T)]
    obj = Board(cols, rows, 1.0).object_points().astype(np.float64)
    out = []
    for name, grid in cands:
        perm = grid.ravel().copy()
        Rs, ts = _rigid_fit(obj, obj[perm])
        out.append((name, perm, Rs, ts))
    return tuple(out)


def _rigid_fit(src: np.ndarray, dst: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Proper rotation R and t with dst ≈ src @ R.T + t (Kabsch)."""
    cs, cd = src.mean(0), dst.mean(0)
    H = (src - cs).T @ (dst - cd)
    U, _, Vt = np.linalg.svd(H)
    D = np.diag([1.0, 1.0, np.sign(np.linalg.det(Vt.T @ U.T)) or 1.0])
    R = Vt.T @ D @ U.T
    return R, cd - R @ cs


def _directions(corners: np.ndarray, board: Board) -> tuple[np.ndarray, np.ndarray]:
    g = np.asarray(corners, dtype=np.float64).reshape(board.rows, board.cols, 2)
    u = (g[:, -1] - g[:, 0]).mean(axis=0)      # along a row (board x)
    v = (g[-1, :] - g[0, :]).mean(axis=0)      # down a column (board y)
    return u, v


def _unit(a: np.ndarray) -> np.ndarray:
    n = np.linalg.norm(a)
    return a / n if n > 0 else a


def _handed(corners: np.ndarray, board: Board) -> bool:
    """True when board x, y appear as image x-right, y-down turn (board z away from the camera)."""
    u, v = _directions(corners, board)
    return float(u[0] * v[1] - u[1] * v[0]) > 0


def canonical_order(corners: np.ndarray, board: Board) -> np.ndarray:
    """Relabel so that the board z points away from the camera and rows run downwards."""
    best, best_score = corners, -np.inf
    for _, perm, _, _ in board_symmetries(board.cols, board.rows):
        c = corners[perm]
        if not _handed(c, board):
            continue
        u, v = _directions(c, board)
        score = _unit(u)[0] + _unit(v)[1]
        if score > best_score + 1e-9:
            best, best_score = c, score
    return np.ascontiguousarray(best)


def match_order(left: np.ndarray, right: np.ndarray, board: Board) -> tuple[np.ndarray, str, float]:
    """Relabel the right corners so that their grid directions agree with the left ones.

    Returns (right corners, name of the symmetry applied or "", agreement score in [-2, 2],
    the sum of the cosines between the row and between the column directions).
    """
    ul, vl = (_unit(a) for a in _directions(left, board))
    best = (right, "", -np.inf)
    for name, perm, _, _ in board_symmetries(board.cols, board.rows):
        c = right[perm]
        if not _handed(c, board):
            continue
        u, v = (_unit(a) for a in _directions(c, board))
        score = float(ul @ u + vl @ v)
        if score > best[2] + 1e-9:
            best = (np.ascontiguousarray(c), name, score)
    return best
