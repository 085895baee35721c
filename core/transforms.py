"""Homogeneous transforms. Lengths in mm, angles in radians unless a name says _deg.

rpy = (roll, pitch, yaw) applied as R = Rz(yaw) · Ry(pitch) · Rx(roll), as DESIGN.md states.
"""
from __future__ import annotations

import numpy as np


def rot_x(angle: float) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[1.0, 0, 0], [0, c, -s], [0, s, c]])


def rot_y(angle: float) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, 0, s], [0, 1.0, 0], [-s, 0, c]])


def rot_z(angle: float) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1.0]])


def skew(v) -> np.ndarray:
    """The cross-product matrix [v]x of a 3-vector."""
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


def rot_axis(axis, angle: float) -> np.ndarray:
    """Rotation by `angle` (rad) about `axis` (Rodrigues; the axis need not be unit length)."""
    k = np.asarray(axis, dtype=float)
    K = skew(k / np.linalg.norm(k))
    return np.eye(3) + np.sin(angle) * K + (1 - np.cos(angle)) * (K @ K)


def rot_vec(omega) -> np.ndarray:
    """Rotation matrix of a rotation vector ω (rad): about ω/|ω| by |ω| (exp of so(3))."""
    omega = np.asarray(omega, dtype=float)
    angle = float(np.linalg.norm(omega))
    if angle < 1e-12:
        return np.eye(3) + skew(omega)
    return rot_axis(omega, angle)


def rpy_to_matrix(rpy) -> np.ndarray:
    roll, pitch, yaw = rpy
    return rot_z(yaw) @ rot_y(pitch) @ rot_x(roll)


def matrix_to_rpy(R: np.ndarray) -> np.ndarray:
    """Inverse of `rpy_to_matrix` (pitch in [-pi/2, pi/2])."""
    pitch = np.arctan2(-R[2, 0], np.hypot(R[0, 0], R[1, 0]))
    if np.hypot(R[0, 0], R[1, 0]) < 1e-12:  # gimbal lock: put everything in yaw
        return np.array([0.0, pitch, np.arctan2(-R[0, 1], R[1, 1])])
    return np.array([np.arctan2(R[2, 1], R[2, 2]), pitch, np.arctan2(R[1, 0], R[0, 0])])


def make_transform(R: np.ndarray | None = None, t=None) -> np.ndarray:
    T = np.eye(4)
    if R is not None:
        T[:3, :3] = R
    if t is not None:
        T[:3, 3] = np.asarray(t, dtype=float)
    return T


def pose_to_matrix(xyz, rpy) -> np.ndarray:
    """4x4 transform from a position (mm) and roll/pitch/yaw (rad)."""
    return make_transform(rpy_to_matrix(rpy), xyz)


def matrix_to_pose(T: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(xyz mm, rpy rad) of a 4x4 transform."""
    return T[:3, 3].copy(), matrix_to_rpy(T[:3, :3])


def invert(T: np.ndarray) -> np.ndarray:
    R, t = T[:3, :3], T[:3, 3]
    return make_transform(R.T, -R.T @ t)


def transform_points(T: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Apply a 4x4 transform to (N, 3) points."""
    points = np.asarray(points, dtype=float)
    return points @ T[:3, :3].T + T[:3, 3]


def rotation_angle(R: np.ndarray) -> float:
    """Angle (rad) of a rotation matrix."""
    return float(np.arccos(np.clip((np.trace(R) - 1.0) / 2.0, -1.0, 1.0)))


def best_rotation(source: np.ndarray, target: np.ndarray) -> np.ndarray:
    """Rotation R (3x3) minimising Σ |R·source_i − target_i|² (no translation; SVD, no reflection)."""
    U, _, Vt = np.linalg.svd(np.asarray(source, dtype=float).T @ np.asarray(target, dtype=float))
    d = np.sign(np.linalg.det(Vt.T @ U.T)) or 1.0
    return Vt.T @ np.diag([1.0, 1.0, d]) @ U.T


def kabsch(source: np.ndarray, target: np.ndarray) -> np.ndarray:
    """Rigid transform T (4x4) minimising Σ |T·source_i − target_i|² (Kabsch/Umeyama, no scale)."""
    cs, ct = source.mean(axis=0), target.mean(axis=0)
    R = best_rotation(source - cs, target - ct)
    return make_transform(R, ct - R @ cs)
