"""Cross-validation of a stereo calibration (mrcal's lesson).

The used views are split interleaved (even/odd), each half calibrated alone, and for every
pixel of a grid over the image the ray of model A is projected with model B. The camera
frame of each model is only defined up to a rotation (absorbed by the board poses), so the
best rotation between the two models' rays (Kabsch over the grid pixels inside the observed
area) is applied first. With a rotation only, the result does not depend on the working
distance. Reported: RMS and max over the whole image and the RMS over the observed area (the
convex hull of all corners; this is the headline `cross_validation_px`), per camera, plus
the baseline and rotation differences of the two halves.

Units: px, mm, degrees.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

import cv2
import numpy as np

from core.stereo.board import Board
from core.stereo.fit import CalibrationOptions, fit_stereo
from core.stereo.rectification import UNDISTORT_CRITERIA
from core.task import Monitor
from core.transforms import best_rotation, rotation_angle

MIN_VIEWS_PER_HALF = 4


@dataclass
class CameraCrossValidation:
    """Projection differences between the two halves' models of one camera over a grid."""

    grid_u: np.ndarray            # (gw,) px
    grid_v: np.ndarray            # (gh,) px
    diff: np.ndarray              # (gh, gw) px, NaN where a model cannot be inverted
    observed: np.ndarray          # (gh, gw) bool, inside the area the boards covered
    rms_px: float
    max_px: float
    rms_observed_px: float
    rotation_deg: float           # the frame rotation fitted between the two models


@dataclass
class CrossValidation:
    """Two halves of the views calibrated alone and compared (see module notes).

    The headline figure (`cross_validation_px` of the summary) is `rms_observed_px`: where
    the boards were, the two models should agree to about the corner noise; outside it,
    `max_px` shows how far the model is extrapolated.
    """

    rms_px: float                 # over the whole image, both cameras
    max_px: float
    rms_observed_px: float        # inside the observed area (convex hull of all corners), both cameras
    left: CameraCrossValidation
    right: CameraCrossValidation
    baseline_diff_mm: float
    rotation_diff_deg: float
    views_a: list[int]            # pair indices of each half
    views_b: list[int]
    split: str = "interleaved (even / odd pairs)"

    def to_dict(self) -> dict:
        return {"rms_px": self.rms_px, "max_px": self.max_px, "rms_observed_px": self.rms_observed_px,
                "left_rms_px": self.left.rms_px, "right_rms_px": self.right.rms_px,
                "baseline_diff_mm": self.baseline_diff_mm, "rotation_diff_deg": self.rotation_diff_deg,
                "split": self.split}


def cross_validate(board: Board, L: np.ndarray, Rp: np.ndarray, image_size: tuple[int, int],
                   options: CalibrationOptions, indices: Sequence[int] | None = None,
                   monitor: Monitor | None = None) -> CrossValidation:
    """Calibrate the even and the odd views alone and compare the two models (see module notes)."""
    monitor = monitor or Monitor()
    V = len(L)
    indices = list(range(V)) if indices is None else list(indices)
    a = list(range(0, V, 2))
    b = list(range(1, V, 2))
    monitor.step(0.0, "cross-validation: first half")
    fa = fit_stereo(board, L[a], Rp[a], image_size, options)
    monitor.step(0.5, "cross-validation: second half")
    fb = fit_stereo(board, L[b], Rp[b], image_size, options)
    monitor.step(0.95, "cross-validation: comparing the models")
    a_pair, b_pair = fa.file, fb.file
    left = compare_cameras(a_pair.K1, a_pair.D1, b_pair.K1, b_pair.D1, image_size, L.reshape(-1, 2),
                           options.cv_grid_step)
    right = compare_cameras(a_pair.K2, a_pair.D2, b_pair.K2, b_pair.D2, image_size, Rp.reshape(-1, 2),
                            options.cv_grid_step)
    both = np.concatenate([left.diff.ravel(), right.diff.ravel()])
    both = both[np.isfinite(both)]
    obs = np.concatenate([left.diff[left.observed], right.diff[right.observed]])
    obs = obs[np.isfinite(obs)]
    dR = a_pair.R @ b_pair.R.T
    rot = math.degrees(rotation_angle(dR))
    return CrossValidation(
        rms_px=float(np.sqrt(np.mean(both ** 2))) if both.size else float("nan"),
        max_px=float(both.max()) if both.size else float("nan"),
        rms_observed_px=float(np.sqrt(np.mean(obs ** 2))) if obs.size else float("nan"),
        left=left, right=right,
        baseline_diff_mm=float(abs(np.linalg.norm(a_pair.T) - np.linalg.norm(b_pair.T))),
        rotation_diff_deg=rot, views_a=[indices[i] for i in a], views_b=[indices[i] for i in b])


def compare_cameras(Ka, Da, Kb, Db, image_size: tuple[int, int], observed_points: np.ndarray,
                    step: int = 16) -> CameraCrossValidation:
    """Projection difference (px) of model B against model A over a pixel grid.

    Each grid pixel is back-projected with model A to a ray, the best rotation between the
    two models' frames is applied, and the ray is projected with model B.
    """
    w, h = image_size
    us = np.arange(0, w, step, dtype=np.float64)
    vs = np.arange(0, h, step, dtype=np.float64)
    if us[-1] != w - 1:
        us = np.append(us, w - 1.0)
    if vs[-1] != h - 1:
        vs = np.append(vs, h - 1.0)
    uu, vv = np.meshgrid(us, vs)
    px = np.stack([uu.ravel(), vv.ravel()], axis=1)
    ray_a, ok_a = _rays(px, Ka, Da)
    ray_b, ok_b = _rays(px, Kb, Db)
    hull = cv2.convexHull(np.asarray(observed_points, dtype=np.float32).reshape(-1, 1, 2))
    inside = np.array([cv2.pointPolygonTest(hull, (float(x), float(y)), False) >= 0 for x, y in px])
    ok = ok_a & ok_b
    fit_set = ok & inside
    if fit_set.sum() < 3:
        fit_set = ok
    Rab = best_rotation(ray_a[fit_set], ray_b[fit_set])
    rotated = ray_a @ Rab.T
    proj, _ = cv2.projectPoints(rotated.reshape(-1, 1, 3), np.zeros(3), np.zeros(3), Kb, Db)
    diff = np.linalg.norm(proj.reshape(-1, 2) - px, axis=1)
    diff[~ok] = np.nan
    diff = diff.reshape(uu.shape)
    finite = diff[np.isfinite(diff)]
    obs_vals = diff[inside.reshape(uu.shape) & np.isfinite(diff)]
    angle = math.degrees(rotation_angle(Rab))
    return CameraCrossValidation(
        us, vs, diff, inside.reshape(uu.shape),
        float(np.sqrt(np.mean(finite ** 2))) if finite.size else float("nan"),
        float(finite.max()) if finite.size else float("nan"),
        float(np.sqrt(np.mean(obs_vals ** 2))) if obs_vals.size else float("nan"), angle)


def _rays(px: np.ndarray, K, D) -> tuple[np.ndarray, np.ndarray]:
    """Unit rays through pixels, and whether the model maps them back to the same pixel."""
    xy = cv2.undistortPoints(px.reshape(-1, 1, 2), K, D, criteria=UNDISTORT_CRITERIA).reshape(-1, 2)
    rays = np.concatenate([xy, np.ones((len(xy), 1))], axis=1)
    back, _ = cv2.projectPoints(rays.reshape(-1, 1, 3), np.zeros(3), np.zeros(3), K, D)
    ok = np.all(np.isfinite(rays), axis=1) & (np.linalg.norm(back.reshape(-1, 2) - px, axis=1) < 0.05)
    norm = np.linalg.norm(rays, axis=1, keepdims=True)
    return rays / np.where(norm > 0, norm, 1.0), ok
