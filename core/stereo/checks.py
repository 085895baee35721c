"""Plausibility checks of a stereo calibration, whatever file it was read from.

Each failure is one RoboCalError naming the file, the field and what to do:

- K1, K2: a camera matrix [[fx, 0, cx], [0, fy, cy], [0, 0, 1]] with fx, fy > 0 (px), no skew,
  aspect ratio fx/fy within 0.2 … 5, principal point inside the image;
- R: a rotation (R·Rᵀ = I and det R = +1 within 1e-6);
- T: finite and not zero (mm);
- E, F, P2 (when the file gave them): consistent with R, T (and K) — the message says which
  one disagrees;
- R1, R2, P1, P2, Q: a usable rectification (rotations, projection matrices with positive
  focal lengths, a non-zero rectified baseline).

`given` names the matrices the file itself held; computed ones are consistent by construction
and are not compared again.
"""
from __future__ import annotations

import numpy as np

from core.errors import RoboCalError

ASPECT_RANGE = (0.2, 5.0)        # fx/fy; real pixels are close to square
ROTATION_TOL = 1e-6              # orthonormality and det of R, R1, R2
AGREEMENT_TOL = 1e-4             # relative disagreement of E, F, P2 with R, T (files hold ≥ 6 digits)
_REDO = "Export the calibration again from the tool that made it, or calibrate again with RoboCal."


def skew(t: np.ndarray) -> np.ndarray:
    """[t]×: the cross-product matrix of a 3-vector."""
    x, y, z = np.asarray(t, dtype=float).reshape(3)
    return np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])


def check_cameras_and_pose(image_size, K1, K2, R, T, source) -> None:
    """The checks of K1, K2, R and T: what must hold before anything is computed from them."""
    w, h = image_size
    for key, K in (("K1", K1), ("K2", K2)):
        _camera_matrix(np.asarray(K, float), w, h, source, key)
    _rotation(np.asarray(R, float), source, "R")
    T = np.asarray(T, float).reshape(3)
    if not np.all(np.isfinite(T)) or not np.linalg.norm(T) > 1e-9:
        raise RoboCalError(f"the translation between the cameras must be finite and not zero, got {T.tolist()}",
                           source=source, field="T", hint=_REDO)


def check_stereo(sf, source, given=frozenset({"E", "F", "R1", "R2", "P1", "P2", "Q"})) -> None:
    """Raise a RoboCalError for the first implausible or inconsistent part of `sf` (a StereoFile)."""
    check_cameras_and_pose(sf.image_size, sf.K1, sf.K2, sf.R, sf.T, source)
    T = np.asarray(sf.T, float).reshape(3)
    if "E" in given:
        _agree(np.asarray(sf.E, float), skew(T) @ sf.R, source, "E",
               "the essential matrix disagrees with R and T")
    if "F" in given:
        E_of_F = np.asarray(sf.K2, float).T @ np.asarray(sf.F, float) @ np.asarray(sf.K1, float)
        _agree(E_of_F, skew(T) @ sf.R, source, "F",
               "the fundamental matrix disagrees with K1, K2, R and T")
    _rectification(sf, T, source, given)


def _camera_matrix(K: np.ndarray, w: int, h: int, source, key: str) -> None:
    fx, fy, cx, cy = K[0, 0], K[1, 1], K[0, 2], K[1, 2]
    if not (fx > 0 and fy > 0):
        raise RoboCalError(f"not a camera matrix: the focal lengths fx = {fx:g}, fy = {fy:g} px must be positive",
                           source=source, field=key, hint=_REDO)
    if K[1, 0] != 0 or K[2, 0] != 0 or K[2, 1] != 0 or abs(K[2, 2] - 1.0) > 1e-9:
        raise RoboCalError("not a camera matrix: expected [[fx, 0, cx], [0, fy, cy], [0, 0, 1]]",
                           source=source, field=key, hint=_REDO)
    if abs(K[0, 1]) > 1e-9 * fx:
        raise RoboCalError(f"the camera matrix has a skew of {K[0, 1]:g} px, which OpenCV's camera model "
                           "(and RoboCal) cannot use", source=source, field=key,
                           hint="Calibrate again without estimating the skew.")
    aspect = fx / fy
    if not ASPECT_RANGE[0] <= aspect <= ASPECT_RANGE[1]:
        raise RoboCalError(f"implausible aspect ratio fx/fy = {aspect:.3g} (expected {ASPECT_RANGE[0]} … "
                           f"{ASPECT_RANGE[1]})", source=source, field=key,
                           hint="Check that fx and fy are in pixels. " + _REDO)
    if not (0 <= cx <= w and 0 <= cy <= h):
        raise RoboCalError(f"the principal point ({cx:g}, {cy:g}) px is outside the {w}x{h} image",
                           source=source, field=key,
                           hint="Check the image size (image_width, image_height) and that K is in pixels.")


def _rotation(R: np.ndarray, source, key: str, what: str = "not a rotation matrix") -> None:
    if R.shape != (3, 3) or not np.all(np.isfinite(R)):
        raise RoboCalError(f"{what} (expected 3x3 finite numbers)", source=source, field=key, hint=_REDO)
    off = float(np.abs(R @ R.T - np.eye(3)).max())
    det = float(np.linalg.det(R))
    if off > ROTATION_TOL or abs(det - 1.0) > ROTATION_TOL:
        raise RoboCalError(f"{what} (R·Rᵀ differs from the identity by {off:.2g}, det = {det:.6g})",
                           source=source, field=key, hint=_REDO)


def _agree(given: np.ndarray, expected: np.ndarray, source, key: str, problem: str) -> None:
    """`given` equal to `expected` up to scale and sign (essential and fundamental matrices)."""
    a = given / (np.linalg.norm(given) or 1.0)
    b = expected / np.linalg.norm(expected)
    difference = min(np.linalg.norm(a - b), np.linalg.norm(a + b))
    if not np.isfinite(difference) or difference > AGREEMENT_TOL:
        raise RoboCalError(f"{problem} (relative difference {difference:.2g})", source=source, field=key,
                           hint=f"Remove {key} from the file to have it computed from R and T, or "
                                "export the calibration again.")


def projection_translation(P: np.ndarray, source, key: str) -> np.ndarray:
    """The translation of a rectified projection matrix K'·[I | t] (t in mm)."""
    P = np.asarray(P, float)
    if not (P[0, 0] > 0 and P[1, 1] > 0 and P[1, 0] == 0 and np.allclose(P[2, :3], [0, 0, 1], atol=1e-9)):
        raise RoboCalError("not a rectified projection matrix [[f, 0, cx, tx], [0, f, cy, ty], [0, 0, 1, 0]] "
                           "with a positive focal length", source=source, field=key,
                           hint="Remove R1, R2, P1, P2, Q to have the rectification computed, or export again.")
    return np.linalg.solve(P[:, :3], P[:, 3])


def _rectification(sf, T: np.ndarray, source, given) -> None:
    hint = "Remove R1, R2, P1, P2, Q from the file to have the rectification computed, or export it again."
    for key in ("R1", "R2"):
        _rotation(np.asarray(getattr(sf, key), float), source, key, "not a rectification rotation")
    t1 = projection_translation(sf.P1, source, "P1")
    t2 = projection_translation(sf.P2, source, "P2")
    baseline = t2 - t1                      # right camera minus left, rectified frame, mm
    if not np.linalg.norm(baseline[:2]) > 1e-9:
        raise RoboCalError("the rectified baseline is zero (P2 has no translation)", source=source, field="P2",
                           hint=hint)
    Q = np.asarray(sf.Q, float)
    if "Q" in given and not (np.all(np.isfinite(Q)) and abs(np.linalg.det(Q)) > 0):
        raise RoboCalError("the disparity-to-depth matrix is singular", source=source, field="Q", hint=hint)
    if not given & {"R1", "R2", "P1", "P2"}:
        return
    R1, R2 = np.asarray(sf.R1, float), np.asarray(sf.R2, float)
    turn = float(np.abs(R2 @ sf.R @ R1.T - np.eye(3)).max())
    if turn > AGREEMENT_TOL:
        raise RoboCalError(f"R1 and R2 do not rectify the rotation R (R2·R·R1ᵀ differs from the identity by "
                           f"{turn:.2g})", source=source, field="R2", hint=hint)
    expected = R2 @ T
    gap = float(np.linalg.norm(baseline - expected)) / float(np.linalg.norm(T))
    if gap > AGREEMENT_TOL:
        raise RoboCalError(f"P2 disagrees with T: P2 gives a rectified baseline of "
                           f"{np.round(baseline, 3).tolist()} mm, R2·T is {np.round(expected, 3).tolist()} mm "
                           f"(check the length unit of both)", source=source, field="P2", hint=hint)
