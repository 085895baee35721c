"""Small plane-geometry helpers of the marker pipeline: quadrilaterals, lines, homographies
(the map between raw and "ideal" pixels is core.camera.PixelMap).

Pixel convention everywhere: (0, 0) is the centre of the top-left pixel, x right, y down.
A quadrilateral is (4, 2) corners in the order top-left, top-right, bottom-right, bottom-left
(clockwise on screen); side k runs from corner k to corner k + 1 and its outward normal is
(τy, −τx) for the unit tangent τ.
"""
from __future__ import annotations

import numpy as np


# -- quadrilaterals ------------------------------------------------------------------------------

def order_corners(pts: np.ndarray) -> np.ndarray:
    """4 points in the order top-left, top-right, bottom-right, bottom-left (clockwise on
    screen), starting from the one nearest the top-left (smallest x + y)."""
    pts = np.asarray(pts, dtype=float).reshape(4, 2)
    c = pts.mean(axis=0)
    ang = np.arctan2(pts[:, 1] - c[1], pts[:, 0] - c[0])      # y down: increasing = clockwise
    pts = pts[np.argsort(ang)]
    start = int(np.argmin(pts.sum(axis=1)))
    return np.roll(pts, -start, axis=0)


def signed_area(quad: np.ndarray) -> float:
    """Shoelace area; positive for the clockwise-on-screen order (y down)."""
    q = np.asarray(quad, dtype=float)
    x, y = q[:, 0], q[:, 1]
    return 0.5 * float(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y))


def is_convex(quad: np.ndarray) -> bool:
    q = np.asarray(quad, dtype=float)
    d1 = np.roll(q, -1, axis=0) - q
    d2 = np.roll(d1, -1, axis=0)
    cross = d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0]
    return bool(np.all(cross > 0) or np.all(cross < 0))


def side_lengths(quad: np.ndarray) -> np.ndarray:
    q = np.asarray(quad, dtype=float)
    return np.linalg.norm(np.roll(q, -1, axis=0) - q, axis=1)


def diagonal_intersection(quad: np.ndarray) -> np.ndarray:
    """Intersection of the diagonals (corner 0–2 and 1–3): the image of the square's centre,
    exact under perspective (a homography maps lines to lines and incidences to incidences)."""
    q = np.asarray(quad, dtype=float)
    (x0, y0), (x1, y1), (x2, y2), (x3, y3) = q
    # lines through (0, 2) and (1, 3) as a·x + b·y = c, intersected by Cramer's rule
    a1, b1 = y2 - y0, x0 - x2
    c1 = a1 * x0 + b1 * y0
    a2, b2 = y3 - y1, x1 - x3
    c2 = a2 * x1 + b2 * y1
    det = a1 * b2 - a2 * b1
    return np.array([(c1 * b2 - c2 * b1) / det, (a1 * c2 - a2 * c1) / det])


def line_intersection(l1, l2) -> np.ndarray:
    """Intersection of lines given as (nx, ny, rho) with n·p = rho."""
    det = float(l1[0] * l2[1] - l1[1] * l2[0])
    if abs(det) < 1e-12:
        raise np.linalg.LinAlgError("parallel lines")
    return np.array([(l1[2] * l2[1] - l1[1] * l2[2]) / det, (l1[0] * l2[2] - l1[2] * l2[0]) / det])


def corners_from_lines(lines: np.ndarray) -> np.ndarray:
    """Corner k = intersection of side k − 1 and side k (sides as (nx, ny, rho))."""
    return np.array([line_intersection(lines[(k - 1) % 4], lines[k]) for k in range(4)])


def line_through(p0, p1) -> np.ndarray:
    """(nx, ny, rho) of the line from p0 to p1, n the outward normal of a clockwise outline."""
    p0, p1 = np.asarray(p0, dtype=float), np.asarray(p1, dtype=float)
    t = (p1 - p0) / np.linalg.norm(p1 - p0)
    n = np.array([t[1], -t[0]])
    return np.array([n[0], n[1], float(n @ p0)])


def expand_quad(quad: np.ndarray, factor: float) -> np.ndarray:
    """The quadrilateral scaled by `factor` about its diagonal intersection (2D, approximate
    for a perspective view; used for regions of interest only)."""
    c = diagonal_intersection(quad)
    return c + factor * (np.asarray(quad, dtype=float) - c)


def map_points(H: np.ndarray, pts: np.ndarray) -> np.ndarray:
    """Points (..., 2) through a 3x3 homography."""
    pts = np.asarray(pts, dtype=float)
    flat = pts.reshape(-1, 2)
    h = flat @ H[:, :2].T + H[:, 2]
    return (h[:, :2] / h[:, 2:3]).reshape(pts.shape)


def bounding_box(pts: np.ndarray, pad: float, size: tuple[int, int]) -> tuple[int, int, int, int]:
    """Integer box (x0, y0, x1, y1), x1/y1 exclusive, holding the points plus `pad`, clipped
    to an image of `size` (width, height)."""
    pts = np.asarray(pts, dtype=float).reshape(-1, 2)
    w, h = size
    x0 = max(int(np.floor(pts[:, 0].min() - pad)), 0)
    y0 = max(int(np.floor(pts[:, 1].min() - pad)), 0)
    x1 = min(int(np.ceil(pts[:, 0].max() + pad)) + 1, w)
    y1 = min(int(np.ceil(pts[:, 1].max() + pad)) + 1, h)
    return x0, y0, max(x1, x0), max(y1, y0)


def inside_image(pts: np.ndarray, size: tuple[int, int], margin: float = 0.0) -> bool:
    pts = np.asarray(pts, dtype=float).reshape(-1, 2)
    w, h = size
    return bool(np.all((pts[:, 0] >= margin - 0.5) & (pts[:, 0] <= w - 0.5 - margin)
                       & (pts[:, 1] >= margin - 0.5) & (pts[:, 1] <= h - 0.5 - margin)))
