"""What the stereo calibration's own uncertainty adds to a triangulated point's covariance.

A located point's σ (core/marker/triangulation.py) propagates the image noise only: it is the
scatter of the point over repeated images with the calibration held exact. The calibration's
parameters are themselves estimates (their standard deviations from the joint fit,
core/stereo/uncertainty.py); their error is one systematic error shared by every point
measured with that stereo.yaml. Here it is propagated through triangulation:

    Σ_cal(X) = J · Σ_p · Jᵀ,    J = ∂X/∂p by central differences,

over p = fx, fy, cx, cy of both cameras, the rotation vector (rx, ry, rz, deg) and T (tx, ty,
tz, mm) between them (file.TRIANGULATION_PARAMETERS), Σ_p their covariance from the
joint fit with its correlations: the point is projected with the calibration, then
triangulated again with one parameter moved. The distortion coefficients' uncertainty is not
included (their effect depends on where in the images the point is seen).

Units: mm (points, covariance mm²), px (intrinsics), deg (rotation), mm (T).
"""
from __future__ import annotations

import math
from pathlib import Path

import cv2
import numpy as np

from core.errors import RoboCalError
from core.files import read_json
from core.stereo.file import TRIANGULATION_PARAMETERS as PARAMETERS

STEREO = PARAMETERS[8:]
_STEP = {"px": 0.5, "deg": 0.01, "mm": 0.05}        # central-difference steps (the fit is linear at this scale)


def _triangulate(K1, K2, R, T, uv1, uv2) -> np.ndarray:
    """The point (mm, left camera frame) whose pinhole projections are uv1, uv2 (linear, DLT)."""
    P1 = K1 @ np.hstack([np.eye(3), np.zeros((3, 1))])
    P2 = K2 @ np.hstack([R, T.reshape(3, 1)])
    A = np.array([uv1[0] * P1[2] - P1[0], uv1[1] * P1[2] - P1[1],
                  uv2[0] * P2[2] - P2[0], uv2[1] * P2[2] - P2[1]])
    X = np.linalg.svd(A)[2][-1]
    return X[:3] / X[3]


def _project(K, R, T, X) -> np.ndarray:
    x = K @ (R @ X + T)
    return x[:2] / x[2]


def _moved(K1, K2, rvec, T, name: str, delta: float):
    """K1, K2, R, T with parameter `name` moved by delta (px, deg or mm)."""
    K1, K2, rvec, T = K1.copy(), K2.copy(), rvec.copy(), T.copy()
    if name in STEREO:
        i = STEREO.index(name)
        if i < 3:
            rvec[i] += math.radians(delta)
        else:
            T[i - 3] += delta
    else:
        n, side = name.split("_")
        K = K1 if side == "left" else K2
        r, c = {"fx": (0, 0), "fy": (1, 1), "cx": (0, 2), "cy": (1, 2)}[n]
        K[r, c] += delta
    return K1, K2, cv2.Rodrigues(rvec)[0], T


def calibration_covariance(K1, K2, R, T, point, covariance) -> np.ndarray:
    """(3, 3) covariance (mm²) of a point triangulated at `point` (mm, left camera frame) due to
    the calibration's parameter covariance (14 x 14 over PARAMETERS: px, deg, mm)."""
    K1, K2 = np.asarray(K1, float), np.asarray(K2, float)
    R, T, X = np.asarray(R, float), np.asarray(T, float).reshape(3), np.asarray(point, float).reshape(3)
    uv1, uv2 = _project(K1, np.eye(3), np.zeros(3), X), _project(K2, R, T, X)
    rvec = cv2.Rodrigues(R)[0].ravel()
    J = np.zeros((3, len(PARAMETERS)))
    for k, name in enumerate(PARAMETERS):
        h = _STEP["deg" if name in STEREO[:3] else "mm" if name in STEREO else "px"]
        plus = _triangulate(*_moved(K1, K2, rvec, T, name, +h), uv1, uv2)
        minus = _triangulate(*_moved(K1, K2, rvec, T, name, -h), uv1, uv2)
        J[:, k] = (plus - minus) / (2 * h)
    cov = J @ np.asarray(covariance, float) @ J.T
    return (cov + cov.T) / 2


def parameter_covariance(details: str | Path, K1, K2, T) -> np.ndarray | None:
    """The covariance of PARAMETERS kept in the stereo details file (stereo.json,
    "parameter_covariance"), when it belongs to this calibration (its focal lengths and T agree
    with the file's parameter table); None otherwise (no file, a calibration imported from
    another tool, or the details of another calibration)."""
    path = Path(details)
    if not path.is_file():
        return None
    try:
        data = read_json(path)
    except RoboCalError:
        return None
    block, rows = data.get("parameter_covariance"), data.get("parameters")
    if not isinstance(block, dict) or block.get("names") != list(PARAMETERS) or not isinstance(rows, list):
        return None
    try:
        matrix = np.array(block.get("matrix"), dtype=float)
    except (TypeError, ValueError):
        return None
    if matrix.shape != (len(PARAMETERS),) * 2 or not np.all(np.isfinite(matrix)):
        return None
    value = {(r.get("name") if r.get("group") == "stereo" else f"{r.get('name')}_{r.get('group')}"): r.get("value")
             for r in rows if isinstance(r, dict)}
    expected = {"fx_left": K1[0, 0], "fx_right": K2[0, 0], "tx": T[0], "ty": T[1], "tz": T[2]}
    for key, v in expected.items():
        if not isinstance(value.get(key), (int, float)) or not math.isclose(value[key], float(v), rel_tol=1e-6,
                                                                           abs_tol=1e-9):
            return None
    return matrix
