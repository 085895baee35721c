"""A whole StereoFile from the parts another tool's file holds.

Every stereo calibration file holds the two cameras (K, distortion), the image size and the
pose of the right camera (R, T: X_right = R·X_left + T, mm). What it may leave out is
computed here, the way RoboCal's own calibration computes it:

- E = [T]× R, F = K2⁻ᵀ E K1⁻¹ (scaled so F[2,2] = 1);
- R1, R2, P1, P2, Q by cv2.stereoRectify(flags=CALIB_ZERO_DISPARITY, alpha).

Statistics (RMS errors, the checkerboard) stay unknown (None). The result is checked by
core.stereo.checks, comparing what the file gave with R and T.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import cv2
import numpy as np

from core.errors import RoboCalError
from core.stereo.checks import check_cameras_and_pose, check_stereo, projection_translation, skew
from core.stereo.file import DIST_LENGTHS, StereoFile

_RECTIFICATION = ("R1", "R2", "P1", "P2", "Q")


@dataclass
class StereoParts:
    """What a file gave: cameras and pose always, the rest when present (None: compute it)."""

    image_size: tuple[int, int]
    K1: np.ndarray
    D1: np.ndarray
    K2: np.ndarray
    D2: np.ndarray
    R: np.ndarray
    T: np.ndarray                                # (3,) mm
    E: np.ndarray | None = None
    F: np.ndarray | None = None
    R1: np.ndarray | None = None
    R2: np.ndarray | None = None
    P1: np.ndarray | None = None
    P2: np.ndarray | None = None
    Q: np.ndarray | None = None
    rectify_alpha: float = 0.0
    notes: list[str] = field(default_factory=list)


def distortion(values, source, key: str) -> np.ndarray:
    """OpenCV distortion coefficients (k1, k2, p1, p2[, k3[, k4, k5, k6 …]]), padded to 5."""
    d = np.asarray(values, dtype=float).ravel()
    if d.size not in DIST_LENGTHS:
        raise RoboCalError(f"expected 4, 5, 8, 12 or 14 distortion coefficients, got {d.size}", source=source,
                           field=key, hint="Give the coefficients in OpenCV's order (k1, k2, p1, p2, k3, …).")
    if not np.all(np.isfinite(d)):
        raise RoboCalError("contains values that are not finite numbers", source=source, field=key)
    return np.concatenate([d, np.zeros(5 - d.size)]) if d.size < 5 else d


def complete_stereo(parts: StereoParts, source) -> tuple[StereoFile, list[str]]:
    """The StereoFile of `parts` with E, F and the rectification computed where absent, checked;
    and the names of what was computed."""
    w, h = parts.image_size
    if not (0 < w <= 100_000 and 0 < h <= 100_000):
        raise RoboCalError(f"implausible image size {w}x{h} px (expected 1 … 100000)", source=source,
                           field="image_width")
    K1, K2, R = (np.asarray(m, dtype=float).reshape(3, 3) for m in (parts.K1, parts.K2, parts.R))
    T = np.asarray(parts.T, dtype=float).reshape(3)
    D1, D2 = distortion(parts.D1, source, "D1"), distortion(parts.D2, source, "D2")
    check_cameras_and_pose((w, h), K1, K2, R, T, source)          # before inverting or rectifying anything
    given = {key for key in ("E", "F", *_RECTIFICATION) if getattr(parts, key) is not None}
    computed = []
    E = parts.E
    if E is None:
        E = skew(T) @ R
        computed.append("E")
    F = parts.F
    if F is None:
        F = np.linalg.inv(K2).T @ np.asarray(E, float) @ np.linalg.inv(K1)
        F = F / F[2, 2] if abs(F[2, 2]) > 1e-15 else F
        computed.append("F")
    rect = [getattr(parts, key) for key in _RECTIFICATION]
    present = [key for key, m in zip(_RECTIFICATION, rect) if m is not None]
    if len(present) < 4 or present[:4] != list(_RECTIFICATION[:4]):
        # partial rectifications are not mixed with computed ones: compute all of it
        given -= set(_RECTIFICATION)
        rect = cv2.stereoRectify(K1, D1, K2, D2, (int(w), int(h)), R, T.reshape(3, 1),
                                 flags=cv2.CALIB_ZERO_DISPARITY, alpha=float(parts.rectify_alpha))[:5]
        computed.extend(_RECTIFICATION)
    elif rect[4] is None:                         # Q from P1, P2 (cv2.stereoRectify's formula)
        rect[4] = _disparity_to_depth(np.asarray(rect[2], float), np.asarray(rect[3], float))
        computed.append("Q")
    R1, R2, P1, P2, Q = (np.asarray(m, dtype=float) for m in rect)
    sf = StereoFile((int(w), int(h)), K1, D1, K2, D2, R, T, np.asarray(E, float).reshape(3, 3),
                    np.asarray(F, float).reshape(3, 3), R1.reshape(3, 3), R2.reshape(3, 3), P1.reshape(3, 4),
                    P2.reshape(3, 4), Q.reshape(4, 4), rectify_alpha=float(parts.rectify_alpha))
    check_stereo(sf, source, frozenset(given))
    return sf, computed


def pose_from_rectification(R1, R2, P1, P2, source) -> tuple[np.ndarray, np.ndarray]:
    """R and T of the right camera from a rectified pair alone: with P = K'·[I | t] for each
    camera, X_rect = Rn·X_camera + t, so R = R2ᵀ·R1 and T = R2ᵀ·(t2 − t1), in the length unit
    of P's last column. Side by side t2 − t1 = (−B, 0, 0); one camera above the other (0, −B, 0)."""
    t1 = projection_translation(P1, source, "P1")
    t2 = projection_translation(P2, source, "P2")
    R1, R2 = np.asarray(R1, dtype=float).reshape(3, 3), np.asarray(R2, dtype=float).reshape(3, 3)
    return R2.T @ R1, R2.T @ (t2 - t1)


def _disparity_to_depth(P1: np.ndarray, P2: np.ndarray) -> np.ndarray:
    """Q of a rectified pair (as cv2.stereoRectify builds it), from P1 and P2 (zeros without a
    baseline in P2: the check then names P2)."""
    f, cx, cy = P1[0, 0], P1[0, 2], P1[1, 2]
    if not (P2[0, 0] > 0 and P2[1, 1] > 0 and (P2[0, 3] != 0 or P2[1, 3] != 0)):
        return np.zeros((4, 4))
    if abs(P2[1, 3]) > abs(P2[0, 3]):             # one camera above the other
        ty = P2[1, 3] / P2[1, 1]
        return np.array([[1.0, 0, 0, -cx], [0, 1.0, 0, -cy], [0, 0, 0, f], [0, 0, -1.0 / ty, (cy - P2[1, 2]) / ty]])
    tx = P2[0, 3] / P2[0, 0]
    return np.array([[1.0, 0, 0, -cx], [0, 1.0, 0, -cy], [0, 0, 0, f], [0, 0, -1.0 / tx, (cx - P2[0, 2]) / tx]])


def scale_lengths(parts: StereoParts, mm_per_unit: float) -> StereoParts:
    """`parts` with its lengths (T, E, the translations of P1, P2 and Q) converted to mm."""
    s = float(mm_per_unit)
    if s == 1.0:
        return parts
    parts.T = np.asarray(parts.T, float) * s
    if parts.E is not None:
        parts.E = np.asarray(parts.E, float) * s
    for key in ("P1", "P2"):
        P = getattr(parts, key)
        if P is not None:
            P = np.array(P, dtype=float)
            P[:, 3] *= s
            setattr(parts, key, P)
    if parts.Q is not None:
        Q = np.array(parts.Q, dtype=float)
        Q[3, :] /= s
        parts.Q = Q
    return parts
