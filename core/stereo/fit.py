"""Fitting the camera model of a stereo pair to checkerboard corners.

1. Each camera alone: `cv2.calibrateCameraExtended` with the model chosen in
   `CalibrationOptions` (radial 2/3/6 coefficients, tangential on/off, fixed aspect ratio,
   fixed principal point).
2. Both cameras together: `cv2.stereoCalibrateExtended` starting from step 1, refining the
   intrinsics with R and T (`refine_intrinsics=True`, the default). This is the joint
   maximum-likelihood fit of every corner of both cameras; on the real 640x512 pairs it
   gives a stereo RMS of 0.163 px against 0.166 px with the intrinsics fixed, and it is
   what a plain `cv2.stereoCalibrate(flags=0)` converges to. `refine_intrinsics=False`
   keeps the per-camera intrinsics (OpenCV's CALIB_FIX_INTRINSIC).
3. The residuals of every corner (observed − projected, px) and the rectification
   (`cv2.stereoRectify`, zero disparity, alpha of the options) of the fitted pair.

Units: mm, px.
"""
from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from core.errors import RoboCalError, UsageError
from core.stereo.board import Board
from core.stereo.file import StereoFile

_CRITERIA = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 200, 1e-12)


@dataclass(frozen=True)
class CalibrationOptions:
    """The camera model and checks the user chooses (shown on the page as they are)."""

    radial: int = 3                 # radial coefficients: 2 (k1 k2), 3 (+k3), 6 (rational k1..k6)
    tangential: bool = True         # p1, p2
    fix_aspect: bool = False        # fx/fy kept at 1
    fix_principal: bool = False     # (cx, cy) kept at the image centre
    refine_intrinsics: bool = True  # the stereo step refines the intrinsics (see module notes)
    outlier_k: float = 3.0          # flag views above median + k·σ of the per-view RMS ...
    outlier_min_ratio: float = 2.0  # ... and above this many times the median
    cross_validate: bool = True
    cv_grid_step: int = 16          # px between grid points for the cross-validation
    rectify_alpha: float = 0.0      # 0: only valid pixels in the rectified images

    def validate(self) -> "CalibrationOptions":
        if self.radial not in (2, 3, 6):
            raise UsageError(f"radial coefficients must be 2, 3 or 6 (rational model), got {self.radial}")
        if not self.outlier_k > 0:
            raise UsageError(f"outlier factor k must be positive, got {self.outlier_k}")
        if not self.outlier_min_ratio >= 1.0:
            raise UsageError(f"outlier ratio must be at least 1, got {self.outlier_min_ratio}")
        if not 0.0 <= self.rectify_alpha <= 1.0:
            raise UsageError(f"rectification alpha must be in [0, 1], got {self.rectify_alpha}")
        if self.cv_grid_step < 1:
            raise UsageError(f"cross-validation grid step must be >= 1 px, got {self.cv_grid_step}")
        return self

    @property
    def n_dist(self) -> int:
        """Length of the distortion vector: 8 for the rational model, else 5."""
        return 8 if self.radial == 6 else 5

    def flags(self) -> int:
        """OpenCV calibration flags of the model (without the stereo-step flags)."""
        f = 0
        if self.radial == 2:
            f |= cv2.CALIB_FIX_K3
        elif self.radial == 6:
            f |= cv2.CALIB_RATIONAL_MODEL
        if not self.tangential:
            f |= cv2.CALIB_ZERO_TANGENT_DIST
        if self.fix_aspect:
            f |= cv2.CALIB_FIX_ASPECT_RATIO
        if self.fix_principal:
            f |= cv2.CALIB_FIX_PRINCIPAL_POINT
        return f

    def free_distortion(self) -> list[int]:
        """Indices (OpenCV order k1 k2 p1 p2 k3 k4 k5 k6) of the estimated coefficients."""
        idx = [0, 1]
        if self.tangential:
            idx += [2, 3]
        if self.radial >= 3:
            idx.append(4)
        if self.radial == 6:
            idx += [5, 6, 7]
        return idx

    def describe(self) -> str:
        model = {2: "radial k1 k2", 3: "radial k1 k2 k3", 6: "rational k1..k6"}[self.radial]
        parts = [model, "tangential p1 p2" if self.tangential else "no tangential"]
        if self.fix_aspect:
            parts.append("fx = fy")
        if self.fix_principal:
            parts.append("principal point fixed at the centre")
        parts.append("intrinsics refined in the stereo fit" if self.refine_intrinsics
                     else "intrinsics fixed in the stereo fit")
        return ", ".join(parts)

    def to_dict(self) -> dict:
        return {"radial": self.radial, "tangential": self.tangential, "fix_aspect": self.fix_aspect,
                "fix_principal": self.fix_principal, "refine_intrinsics": self.refine_intrinsics,
                "outlier_k": self.outlier_k, "outlier_min_ratio": self.outlier_min_ratio}



@dataclass
class MonoCalibration:
    """One camera calibrated alone (step 1)."""

    rms: float
    K: np.ndarray
    D: np.ndarray
    std_intrinsics: np.ndarray    # calibrateCameraExtended's (fx fy cx cy k1 k2 p1 p2 k3 k4 k5 k6 ...)
    per_view_rms: np.ndarray
    rvecs: np.ndarray             # (V, 3)
    tvecs: np.ndarray             # (V, 3) mm



@dataclass
class StereoFit:
    """One joint stereo fit: the calibrated pair (`file`: K1 … F, the rectification for
    `CalibrationOptions.rectify_alpha`, the RMS errors), the board poses and residuals, and
    the per-camera fits it started from."""

    file: StereoFile
    rvecs: np.ndarray             # (V, 3) board poses in the left camera frame
    tvecs: np.ndarray             # (V, 3) mm
    residuals_left: np.ndarray    # (V, N, 2) observed − projected, px
    residuals_right: np.ndarray
    mono_left: MonoCalibration
    mono_right: MonoCalibration


def calibrate_mono(obj: np.ndarray, points: np.ndarray, image_size: tuple[int, int],
                   options: CalibrationOptions) -> MonoCalibration:
    """One camera alone with calibrateCameraExtended (the model of `options`)."""
    V = len(points)
    objs = [obj.astype(np.float32)] * V
    imgs = [np.asarray(p, dtype=np.float32).reshape(-1, 1, 2) for p in points]
    K0 = np.eye(3)
    D0 = np.zeros(options.n_dist)
    try:
        rms, K, D, rvecs, tvecs, std_i, _std_e, per_view = cv2.calibrateCameraExtended(
            objs, imgs, image_size, K0, D0, flags=options.flags(), criteria=_CRITERIA)
    except cv2.error as exc:
        raise RoboCalError(f"the camera calibration failed ({_cv_message(exc)})",
                           hint="Add more pairs with the board tilted and in different places.") from exc
    D = _dist_vector(D, options.n_dist)
    return MonoCalibration(float(rms), np.asarray(K, dtype=np.float64), D, np.asarray(std_i).ravel(),
                           np.asarray(per_view).ravel(), np.array(rvecs).reshape(V, 3),
                           np.array(tvecs).reshape(V, 3))


def fit_stereo(board: Board, L: np.ndarray, Rp: np.ndarray, image_size: tuple[int, int],
               options: CalibrationOptions, mono_l: MonoCalibration | None = None,
               mono_r: MonoCalibration | None = None) -> StereoFit:
    """Per-camera calibration (unless given), the joint stereo fit, its residuals and its
    rectification. L, Rp: (V, N, 2) corners px in `board.object_points()` order."""
    obj = board.object_points().astype(np.float64)
    mono_l = mono_l or calibrate_mono(obj, L, image_size, options)
    mono_r = mono_r or calibrate_mono(obj, Rp, image_size, options)
    V = len(L)
    objs = [obj.astype(np.float32)] * V
    il = [np.asarray(p, dtype=np.float32).reshape(-1, 1, 2) for p in L]
    ir = [np.asarray(p, dtype=np.float32).reshape(-1, 1, 2) for p in Rp]
    flags = (options.flags() | cv2.CALIB_USE_INTRINSIC_GUESS) if options.refine_intrinsics \
        else cv2.CALIB_FIX_INTRINSIC | (options.flags() & cv2.CALIB_RATIONAL_MODEL)
    try:
        out = cv2.stereoCalibrateExtended(
            objs, il, ir, mono_l.K.copy(), mono_l.D.copy(), mono_r.K.copy(), mono_r.D.copy(),
            image_size, None, None, flags=flags, criteria=_CRITERIA)
    except cv2.error as exc:
        raise RoboCalError(f"the stereo calibration failed ({_cv_message(exc)})",
                           hint="Check that the pairs show the same board at the same moment.") from exc
    rms, K1, D1, K2, D2, R, T, E, F, rvecs, tvecs, _per_view = out
    K1, K2 = np.asarray(K1, float), np.asarray(K2, float)
    D1, D2 = _dist_vector(D1, options.n_dist), _dist_vector(D2, options.n_dist)
    R, T = np.asarray(R, float).reshape(3, 3), np.asarray(T, float).reshape(3)
    rvecs, tvecs = np.array(rvecs).reshape(V, 3), np.array(tvecs).reshape(V, 3)
    res_l, res_r = _residuals(obj, L, Rp, (K1, D1, K2, D2, R, T), rvecs, tvecs)
    R1, R2, P1, P2, Q, _, _ = cv2.stereoRectify(K1, D1, K2, D2, image_size, R, T.reshape(3, 1),
                                                flags=cv2.CALIB_ZERO_DISPARITY, alpha=options.rectify_alpha)
    size = (int(image_size[0]), int(image_size[1]))
    file = StereoFile(size, K1, D1, K2, D2, R, T, np.asarray(E, float), np.asarray(F, float),
                      R1, R2, P1, P2, Q, _rms(res_l), _rms(res_r), float(rms), board,
                      rectify_alpha=float(options.rectify_alpha))
    return StereoFit(file, rvecs, tvecs, res_l, res_r, mono_l, mono_r)


def _dist_vector(D, n: int) -> np.ndarray:
    d = np.zeros(n)
    given = np.asarray(D, dtype=np.float64).ravel()[:n]
    d[:given.size] = given
    return d


def _cv_message(exc: cv2.error) -> str:
    text = str(exc).strip().splitlines()
    return (text[-1] if text else "OpenCV error").strip()


def _residuals(obj, L, Rp, cameras, rvecs, tvecs) -> tuple[np.ndarray, np.ndarray]:
    """Observed − projected corners (V, N, 2) in both images; cameras = (K1, D1, K2, D2, R, T)."""
    K1, D1, K2, D2, R, T = cameras
    res_l = np.empty_like(L)
    res_r = np.empty_like(Rp)
    rvec_rel = cv2.Rodrigues(R)[0]
    for v, (r, t) in enumerate(zip(rvecs, tvecs)):
        p, _ = cv2.projectPoints(obj, r, t, K1, D1)
        res_l[v] = L[v] - p.reshape(-1, 2)
        r3, t3 = cv2.composeRT(r.reshape(3, 1), t.reshape(3, 1), rvec_rel, T.reshape(3, 1))[:2]
        p, _ = cv2.projectPoints(obj, r3, t3, K2, D2)
        res_r[v] = Rp[v] - p.reshape(-1, 2)
    return res_l, res_r


def _rms(residuals: np.ndarray) -> float:
    """RMS length of (V, N, 2) residual vectors, px."""
    return float(np.sqrt((residuals ** 2).sum(axis=2).mean()))
