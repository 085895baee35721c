"""Pinhole camera with radial and tangential distortion: OpenCV's model (the chapter's eq. 11–19
has the same pinhole and radial terms but a different tangential term, see resources/help/stereo.html).

Frames and units: points in the camera frame in mm (OpenCV convention: z forward, x right,
y down); image coordinates in pixels with (0, 0) at the centre of the top-left pixel.
Distortion coefficients are stored in OpenCV's order: (k1, k2, p1, p2, k3), or with the
rational model (k1, k2, p1, p2, k3, k4, k5, k6), k4..k6 in the radial term's denominator.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import cv2
import numpy as np


@dataclass
class CameraModel:
    K: np.ndarray                      # 3x3 intrinsic matrix (px)
    dist: np.ndarray = field(default_factory=lambda: np.zeros(5))  # k1, k2, p1, p2, k3[, k4, k5, k6]
    width: int = 1280
    height: int = 1024

    def __post_init__(self):
        self.K = np.asarray(self.K, dtype=float).reshape(3, 3)
        given = np.asarray(self.dist, dtype=float).ravel()[:8]
        d = np.zeros(8 if given.size > 5 and np.any(given[5:] != 0) else 5)
        d[:min(given.size, d.size)] = given[:d.size]
        self.dist = d

    @property
    def fx(self) -> float:
        return float(self.K[0, 0])

    @property
    def fy(self) -> float:
        return float(self.K[1, 1])

    @property
    def cx(self) -> float:
        return float(self.K[0, 2])

    @property
    def cy(self) -> float:
        return float(self.K[1, 2])

    @property
    def size(self) -> tuple[int, int]:
        return (self.width, self.height)

    def distort_normalized(self, xy: np.ndarray) -> np.ndarray:
        """Ideal normalised coordinates (N, 2) -> distorted normalised (OpenCV's model; r from the
        principal point)."""
        k1, k2, p1, p2, k3 = self.dist[:5]
        x, y = xy[..., 0], xy[..., 1]
        r2 = x * x + y * y
        radial = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3))
        if self.dist.size == 8:
            k4, k5, k6 = self.dist[5:]
            radial = radial / (1.0 + r2 * (k4 + r2 * (k5 + r2 * k6)))
        xd = x * radial + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x)
        yd = y * radial + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y
        return np.stack([xd, yd], axis=-1)

    def normalized_to_pixels(self, xy: np.ndarray, distort: bool = True) -> np.ndarray:
        """Normalised image coordinates (..., 2) to pixels (distorted first when `distort`)."""
        xy = np.asarray(xy, dtype=float)
        xd = self.distort_normalized(xy) if distort else xy
        u = self.K[0, 0] * xd[..., 0] + self.K[0, 1] * xd[..., 1] + self.K[0, 2]
        v = self.K[1, 1] * xd[..., 1] + self.K[1, 2]
        return np.stack([u, v], axis=-1)

    def project(self, points_cam: np.ndarray, distort: bool = True) -> np.ndarray:
        """Project points given in this camera's frame (N, 3) mm -> (N, 2) px (eq. 11–12 with distortion)."""
        P = np.asarray(points_cam, dtype=float)
        xy = P[..., :2] / P[..., 2:3]
        return self.normalized_to_pixels(xy, distort)

    def project_from(self, points: np.ndarray, R: np.ndarray, t, distort: bool = True) -> np.ndarray:
        """Project points of another frame, X_cam = R · X + t."""
        P = np.asarray(points, dtype=float) @ np.asarray(R, dtype=float).T + np.asarray(t, dtype=float)
        return self.project(P, distort)

    def pixels_to_normalized(self, uv: np.ndarray) -> np.ndarray:
        """Undistort pixels (N, 2) to ideal normalised coordinates (iterative, to ~1e-10)."""
        uv = np.asarray(uv, dtype=np.float64).reshape(-1, 1, 2)
        criteria = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 50, 1e-12)
        out = cv2.undistortPoints(uv, self.K, self.dist, R=np.eye(3), P=np.eye(3), criteria=criteria)
        return out.reshape(-1, 2)

    def pixel_rays(self, uv: np.ndarray) -> np.ndarray:
        """Unit viewing rays (N, 3) in the camera frame through pixels (N, 2)."""
        xy = self.pixels_to_normalized(uv)
        rays = np.concatenate([xy, np.ones((xy.shape[0], 1))], axis=1)
        return rays / np.linalg.norm(rays, axis=1, keepdims=True)

    def in_image(self, uv: np.ndarray, margin: float = 0.0) -> np.ndarray:
        uv = np.asarray(uv, dtype=float)
        return ((uv[..., 0] >= margin - 0.5) & (uv[..., 0] <= self.width - 0.5 - margin)
                & (uv[..., 1] >= margin - 0.5) & (uv[..., 1] <= self.height - 0.5 - margin))

    def scaled(self, factor: float) -> "CameraModel":
        """The same camera sampled `factor` times finer (pixel-centre convention kept)."""
        K = self.K.copy()
        K[0, 0] *= factor
        K[1, 1] *= factor
        K[0, 1] *= factor
        K[0, 2] = factor * K[0, 2] + (factor - 1) / 2.0
        K[1, 2] = factor * K[1, 2] + (factor - 1) / 2.0
        return CameraModel(K, self.dist.copy(), int(round(self.width * factor)), int(round(self.height * factor)))


@dataclass(eq=False)
class PixelMap:
    """Maps raw image pixels to *ideal* pixels, where the image of a straight 3D line is
    straight: lens distortion removed and, for a stereo pair, rectified. Edge lines are fitted
    and intersected in ideal pixels; results are mapped back to raw pixels for display.

    `camera` None: the identity (no lens model known). Otherwise ideal = P · R · undistort(raw)
    with R (3x3, default identity) and P (3x3 or 3x4, default the camera's K)."""

    camera: CameraModel | None = None
    R: np.ndarray = field(default_factory=lambda: np.eye(3))
    P: np.ndarray | None = None

    def __post_init__(self):
        self.R = np.asarray(self.R, dtype=float).reshape(3, 3)
        if self.camera is not None and self.P is None:
            self.P = self.camera.K.copy()
        if self.P is not None:
            self.P = np.asarray(self.P, dtype=float)[:3, :3].copy()

    @property
    def identity(self) -> bool:
        return self.camera is None

    def to_ideal(self, pts: np.ndarray) -> np.ndarray:
        pts = np.asarray(pts, dtype=np.float64)
        if self.identity or pts.size == 0:
            return pts.copy()
        out = cv2.undistortPoints(pts.reshape(-1, 1, 2), self.camera.K, self.camera.dist, R=self.R, P=self.P)
        return out.reshape(pts.shape)

    def to_raw(self, pts: np.ndarray) -> np.ndarray:
        pts = np.asarray(pts, dtype=np.float64)
        if self.identity or pts.size == 0:
            return pts.copy()
        flat = pts.reshape(-1, 2)
        h = np.hstack([flat, np.ones((len(flat), 1))]) @ np.linalg.inv(self.P).T   # rectified normalised
        ray = h @ self.R      # R^T applied to row vectors: back to the camera frame
        xy = ray[:, :2] / ray[:, 2:3]
        return self.camera.normalized_to_pixels(xy).reshape(pts.shape)

    def jacobian_scale(self) -> float:
        """Approximate ideal-pixels-per-raw-pixel near the image centre (for noise scaling)."""
        if self.identity:
            return 1.0
        return float(0.5 * (self.P[0, 0] + self.P[1, 1]) / (0.5 * (self.camera.fx + self.camera.fy)))
