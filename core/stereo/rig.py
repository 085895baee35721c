"""A calibrated stereo pair: two cameras and the pose of the right camera in the left one.

OpenCV's convention: a point X_l in the left camera frame is X_r = R · X_l + T in the right
camera frame (T in mm). The measurement frame of RoboCal is the left camera frame.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from core.camera import CameraModel


@dataclass
class StereoRig:
    left: CameraModel
    right: CameraModel
    R: np.ndarray
    T: np.ndarray

    def __post_init__(self):
        self.R = np.asarray(self.R, dtype=float).reshape(3, 3)
        self.T = np.asarray(self.T, dtype=float).reshape(3)

    @property
    def baseline(self) -> float:
        """Distance between the optical centres (mm)."""
        return float(np.linalg.norm(self.T))

    @property
    def right_centre(self) -> np.ndarray:
        """Right optical centre in the left camera frame (mm)."""
        return -self.R.T @ self.T

    def to_right(self, points_left: np.ndarray) -> np.ndarray:
        return np.asarray(points_left, dtype=float) @ self.R.T + self.T

    def project(self, points_left: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Pixels (N, 2) in the left and right images of points (N, 3) in the left frame."""
        return self.left.project(points_left), self.right.project(self.to_right(points_left))

    def essential(self) -> np.ndarray:
        t = self.T
        tx = np.array([[0, -t[2], t[1]], [t[2], 0, -t[0]], [-t[1], t[0], 0]])
        return tx @ self.R

    def fundamental(self) -> np.ndarray:
        F = np.linalg.inv(self.right.K).T @ self.essential() @ np.linalg.inv(self.left.K)
        return F / F[2, 2] if abs(F[2, 2]) > 1e-15 else F
