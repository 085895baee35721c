"""The marker's orientation from its four outer corners seen by both cameras.

The edge fit (core.marker.edges) gives each side of the outer square as a sub-pixel line with
the covariance of its angle and offset, in rectified pixels of each image. Adjacent lines
meet in the corners; each corner is triangulated from the left and right image (eq. 23–25,
row v the mean of both); the marker frame is the rotation that best maps the printed square
(TrainedMarker.outline_mm: x to the right of the training image, y up, z out of the printed
face) onto the four 3D corners (Kabsch). Its origin is the located reference point.

Uncertainty: the 16 line parameters (angle and offset of 4 sides in 2 images, independent
between sides and images, the edge fit's covariance plus `sigma_floor_px` on the offset) are
propagated to the small rotation δ about the left camera axes (R_true ≈ Exp(δ)·R) through a
central-difference Jacobian of the whole chain: covariance J·C·Jᵀ in rad².
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

from core.marker.triangulation import rectified_geometry


@dataclass
class MarkerOrientation:
    """The marker frame in the left camera (measurement) frame.

    `R` (3x3) maps marker-frame directions to the left camera frame: its columns are the
    marker's printed x, y and normal z (out of the printed face). `covariance` (3x3, rad²)
    is that of the small rotation δ about the left camera axes with R_true ≈ Exp(δ)·R."""

    R: np.ndarray
    covariance: np.ndarray
    origin: np.ndarray                  # (3,) mm, the reference point

    @property
    def rotation_vector(self) -> np.ndarray:
        """Rotation vector of R (rad, left camera frame)."""
        return Rotation.from_matrix(self.R).as_rotvec()

    @property
    def rotation_vector_deg(self) -> np.ndarray:
        return np.rad2deg(self.rotation_vector)

    @property
    def sigma_deg(self) -> np.ndarray:
        """Standard deviations (deg) of the small rotation about the left camera x, y, z."""
        return np.rad2deg(np.sqrt(np.clip(np.diag(self.covariance), 0.0, None)))

    @property
    def normal(self) -> np.ndarray:
        """Unit normal of the printed face (marker z) in the left camera frame."""
        return self.R[:, 2].copy()

    @property
    def marker_covariance(self) -> np.ndarray:
        """The covariance (rad²) about the marker's own x, y, z axes."""
        return self.R.T @ self.covariance @ self.R

    @property
    def normal_sigma_deg(self) -> float:
        """Standard deviation (deg) of the direction of the plane normal (tilt, both axes)."""
        C = self.marker_covariance
        return float(np.rad2deg(np.sqrt(max(C[0, 0] + C[1, 1], 0.0))))

    @property
    def in_plane_deg(self) -> float:
        """Angle (deg) of the marker's x axis about its normal, from the camera's x axis
        projected onto the marker plane."""
        n, x = self.R[:, 2], self.R[:, 0]
        e = np.array([1.0, 0.0, 0.0]) - n[0] * n
        if np.linalg.norm(e) < 1e-9:          # the normal along the camera x axis
            e = np.array([0.0, 1.0, 0.0]) - n[1] * n
        e /= np.linalg.norm(e)
        return float(np.rad2deg(np.arctan2(n @ np.cross(e, x), e @ x)))

    @property
    def in_plane_sigma_deg(self) -> float:
        """Standard deviation (deg) of the rotation about the marker's normal."""
        return float(np.rad2deg(np.sqrt(max(self.marker_covariance[2, 2], 0.0))))

    def to_dict(self) -> dict:
        """A JSON-able summary (robocal locate --json)."""
        return {"units": "deg; rotation vector of the marker frame in the left camera frame",
                "rotation_vector": [float(v) for v in self.rotation_vector_deg],
                "sigma": [float(v) for v in self.sigma_deg],
                "covariance_deg2": (np.rad2deg(np.rad2deg(self.covariance))).tolist(),
                "matrix": self.R.tolist(), "normal": [float(v) for v in self.normal],
                "normal_sigma": self.normal_sigma_deg, "in_plane": self.in_plane_deg,
                "in_plane_sigma": self.in_plane_sigma_deg}


def _params(lines: np.ndarray) -> np.ndarray:
    return np.column_stack([np.arctan2(lines[:, 1], lines[:, 0]), lines[:, 2]]).reshape(-1)


def _corners(params: np.ndarray) -> np.ndarray:
    """(M, 4, 2) corners of M outlines given as (M, 8) side parameters (angle, offset) each;
    corner k is where side k − 1 meets side k."""
    p = params.reshape(-1, 4, 2)
    c, s, rho = np.cos(p[..., 0]), np.sin(p[..., 0]), p[..., 1]
    c0, s0, r0 = np.roll(c, 1, axis=1), np.roll(s, 1, axis=1), np.roll(rho, 1, axis=1)
    det = c0 * s - s0 * c
    return np.stack([(r0 * s - s0 * rho) / det, (c0 * rho - r0 * c) / det], axis=-1)


def corner_points(params: np.ndarray, P1, P2, R1) -> np.ndarray:
    """(M, 4, 3) mm, left camera frame: the outer square's corners triangulated from (M, 16)
    side parameters, the left outline's 8 then the right's (rectified px)."""
    cl, cr = _corners(params[:, :8]), _corners(params[:, 8:])
    f, cx, cy, cx_r, b = rectified_geometry(P1, P2)
    d = (cl[..., 0] - cr[..., 0]) - (cx - cx_r)
    Z = f * b / d
    X = (cl[..., 0] - cx) * Z / f
    Y = (0.5 * (cl[..., 1] + cr[..., 1]) - cy) * Z / f
    return np.stack([X, Y, Z], axis=-1) @ np.asarray(R1, dtype=float)   # rows: R1ᵀ·p


def frame_rotations(square_mm: np.ndarray, corners_mm: np.ndarray) -> np.ndarray:
    """(M, 3, 3) rotations that best map the printed square's corners onto each set of
    measured ones (M, 4, 3) (Kabsch, no reflection)."""
    A = square_mm - square_mm.mean(axis=0)
    B = corners_mm - corners_mm.mean(axis=1, keepdims=True)
    U, _, Vt = np.linalg.svd(np.einsum("ki,mkj->mij", A, B))
    V, Ut = np.transpose(Vt, (0, 2, 1)), np.transpose(U, (0, 2, 1))
    D = np.ones((len(B), 3))
    D[:, 2] = np.sign(np.linalg.det(V @ Ut))
    return (V * D[:, None, :]) @ Ut


def marker_orientation(left_outline, right_outline, rectification, outer_size: float,
                       origin: np.ndarray, *, sigma_floor_px: float = 0.0) -> MarkerOrientation | None:
    """The marker frame from the fitted outlines (core.marker.edges.OutlineFit, rectified) of
    both images, or None when a corner does not triangulate in front of the cameras.

    `outer_size` (mm) is the printed outer square's side (its value does not change R);
    `origin` the located reference point (mm)."""
    s = outer_size / 2.0
    square = np.array([[-s, s, 0.0], [s, s, 0.0], [s, -s, 0.0], [-s, -s, 0.0]])
    x0 = np.concatenate([_params(left_outline.lines), _params(right_outline.lines)])
    C = np.zeros((16, 16))
    for k, side in enumerate(list(left_outline.sides) + list(right_outline.sides)):
        C[2 * k:2 * k + 2, 2 * k:2 * k + 2] = side.line_cov + np.diag([0.0, sigma_floor_px ** 2])
    h = np.where(np.arange(16) % 2 == 0, 1e-6, 1e-4)       # rad for angles, px for offsets
    X = np.vstack([x0, x0 + np.diag(h), x0 - np.diag(h)])  # the point, then central differences
    pts = corner_points(X, rectification.P1, rectification.P2, rectification.R1)
    if not np.all(np.isfinite(pts)) or np.any(pts[..., 2] <= 0):
        return None
    R = frame_rotations(square, pts)
    turn = Rotation.from_matrix(R[1:17] @ np.transpose(R[17:], (0, 2, 1))).as_rotvec()
    J = (turn / (2 * h[:, None])).T
    return MarkerOrientation(R=R[0], covariance=J @ C @ J.T, origin=np.asarray(origin, dtype=float).copy())
