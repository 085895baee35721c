"""Triangulation of a point seen by both cameras, with its predicted uncertainty.

Rectified case (eq. 23–25): after rectification both image rows coincide, the disparity
d = u_l − u_r gives depth Z = f·b / (d − (c_x,l − c_x,r)), then X = (u_l − c_x)·Z/f,
Y = (v − c_y)·Z/f in the rectified left frame, rotated back into the left camera frame.
General case (eq. 22): linear (DLT) triangulation from both projection equations, refined
by minimising the reprojection error in both (distorted) images.
All 3D points are in mm in the left camera frame.
"""
from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np
from scipy.optimize import least_squares

from core.errors import RoboCalError
from core.stereo.rig import StereoRig


@dataclass
class Triangulated:
    point: np.ndarray          # (3,) mm, left camera frame
    covariance: np.ndarray     # (3, 3) mm², from the pixel noise given
    reprojection_px: float     # RMS reprojection error in both images (general case), else 0

    @property
    def sigma(self) -> np.ndarray:
        """Standard deviation along x, y, z (mm)."""
        return np.sqrt(np.diag(self.covariance))


def rectified_geometry(P1: np.ndarray, P2: np.ndarray) -> tuple[float, float, float, float, float]:
    """(f, cx_left, cy, cx_right, baseline mm) of rectified projection matrices (cv2.stereoRectify)."""
    f = float(P1[0, 0])
    baseline = -float(P2[0, 3]) / float(P2[0, 0])
    return f, float(P1[0, 2]), float(P1[1, 2]), float(P2[0, 2]), baseline


def triangulate_rectified(u_left: float, v: float, disparity: float, P1: np.ndarray, P2: np.ndarray,
                          R1: np.ndarray, sigma_px: float = 0.05) -> Triangulated:
    """Eq. (23)–(25) from a rectified left point (px) and its disparity d = u_l − u_r (px).

    The covariance propagates independent errors of σ = `sigma_px` on u_l, v and u_r (the left
    reference point and the matched right position). R1 rotates the left camera frame into
    the rectified one (cv2.stereoRectify); the point is returned in the left camera frame."""
    f, cx, cy, cx_r, b = rectified_geometry(P1, P2)
    d = disparity - (cx - cx_r)
    if not d > 0:
        raise RoboCalError(f"disparity {disparity:.2f} px gives no point in front of the cameras",
                           hint="The match along the epipolar line is wrong; the pose is rejected.")
    Z = f * b / d
    X = (u_left - cx) * Z / f
    Y = (v - cy) * Z / f
    # d(X, Y, Z) / d(u_l, v, u_r), with d = u_l - u_r - (cx - cx_r)
    J = np.array([[Z / f - X / d, 0.0, X / d],
                  [-Y / d, Z / f, Y / d],
                  [-Z / d, 0.0, Z / d]])
    cov_rect = sigma_px ** 2 * (J @ J.T)
    R1 = np.asarray(R1, dtype=float)
    point = R1.T @ np.array([X, Y, Z])
    return Triangulated(point, R1.T @ cov_rect @ R1, 0.0)


def triangulate_linear(rig: StereoRig, uv_left: np.ndarray, uv_right: np.ndarray) -> np.ndarray:
    """Eq. (22): DLT on undistorted normalised coordinates; (N, 2) pixels -> (N, 3) mm."""
    xl = rig.left.pixels_to_normalized(np.atleast_2d(uv_left))
    xr = rig.right.pixels_to_normalized(np.atleast_2d(uv_right))
    P_l = np.hstack([np.eye(3), np.zeros((3, 1))])
    P_r = np.hstack([rig.R, rig.T.reshape(3, 1)])
    X = cv2.triangulatePoints(P_l, P_r, xl.T.astype(float), xr.T.astype(float))
    return (X[:3] / X[3]).T


def _reprojection(point: np.ndarray, rig: StereoRig, uv_left, uv_right) -> np.ndarray:
    pl, pr = rig.project(point[None])
    return np.concatenate([pl[0] - uv_left, pr[0] - uv_right])


def triangulate_general(rig: StereoRig, uv_left, uv_right, sigma_px: float = 0.05) -> Triangulated:
    """Eq. (22) for unrectified pixels: linear estimate, then reprojection refinement;
    covariance σ²(JᵀJ)⁻¹ of the 4 image coordinates with respect to the point."""
    uv_left = np.asarray(uv_left, dtype=float).reshape(2)
    uv_right = np.asarray(uv_right, dtype=float).reshape(2)
    start = triangulate_linear(rig, uv_left, uv_right)[0]
    if not start[2] > 0:
        raise RoboCalError("the two image points meet behind the cameras",
                           hint="The left and right points do not belong to the same object.")
    fit = least_squares(_reprojection, start, args=(rig, uv_left, uv_right), method="lm",
                        x_scale=np.maximum(np.abs(start), 1.0), xtol=1e-12, ftol=1e-12)
    J = fit.jac
    covariance = sigma_px ** 2 * np.linalg.inv(J.T @ J)
    rms = float(np.sqrt(np.mean(fit.fun ** 2)))
    return Triangulated(fit.x, covariance, rms)
