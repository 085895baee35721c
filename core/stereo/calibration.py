"""Stereo calibration from checkerboard corners: intrinsics, distortion, extrinsics,
rectification, per-view and per-corner errors, uncertainty and cross-validation.

Steps (`calibrate_stereo` for detections, `calibrate_points` for bare corner lists):

1. Each camera alone: `cv2.calibrateCameraExtended` with the model chosen in
   `CalibrationOptions` (radial 2/3/6 coefficients, tangential on/off, fixed aspect ratio,
   fixed principal point).
2. Corner order against the stereo geometry: for every pair, the relative pose
   R_i = R_right,i · R_left,iᵀ follows from the two board poses; it must be the same for
   all pairs. Each pair's right labelling is tried under every board symmetry
   (`core.stereo.checkerboard.board_symmetries`); the relative rotation shared by most pairs wins,
   pairs are relabelled to agree with it, and a pair that agrees under no labelling
   (wrong pairing, board moved between the two exposures) is dropped with a reason.
3. Both cameras together: `cv2.stereoCalibrateExtended` starting from step 1, refining the
   intrinsics with R and T (`refine_intrinsics=True`, the default). This is the joint
   maximum-likelihood fit of every corner of both cameras; on the real 640x512 pairs it
   gives a stereo RMS of 0.163 px against 0.166 px with the intrinsics fixed, and it is
   what a plain `cv2.stereoCalibrate(flags=0)` converges to. `refine_intrinsics=False`
   keeps the per-camera intrinsics (OpenCV's CALIB_FIX_INTRINSIC).
4. Residuals of every corner (observed − projected, px), per-view RMS, automatic outlier
   flags: a view is flagged when its stereo RMS exceeds median + k·σ, σ = 1.4826·MAD
   (a robust standard deviation, so that the outliers themselves do not hide), k = 3, and
   also exceeds twice the median. (The floor matters on clean data: rendered pairs have
   per-view RMS 0.022–0.047 px, MAD-σ 0.003 px; oblique views are a little noisier but
   not wrong. On the real pairs the floor is 0.29 px and pair 15, 0.30 px, is flagged.)
   Flagged views are only flagged; `calibrate_stereo(..., exclude=[...])` recalibrates
   without the views the user removes.
5. Standard deviations of all parameters, including R, T and the baseline, from the
   Jacobian of the joint fit at the solution: Σ = σ̂²(JᵀJ)⁻¹, σ̂² = SSR / (m − n).
   (`stereoCalibrateExtended` gives no standard deviations; the per-camera ones of
   `calibrateCameraExtended` are kept in `mono_left`/`mono_right` for comparison.)
6. Rectification with `cv2.stereoRectify` (alpha 0, zero disparity) and the epipolar error
   of the matched corners after rectification: |y_left − y_right| (|x| for a vertical rig)
   of the undistorted, rectified corners, px, RMS and max, as ROS shows it.
7. Cross-validation (mrcal's lesson): the used views are split interleaved (even/odd),
   each half calibrated alone, and for every pixel of a grid over the image the ray of
   model A is projected with model B. The camera frame of each model is only defined up to
   a rotation (absorbed by the board poses), so the best rotation between the two models'
   rays (Kabsch over the grid pixels inside the observed area) is applied first. With a
   rotation only, the result does not depend on the working distance. Reported: RMS and
   max over the whole image and the RMS over the observed area (the convex hull of all
   corners; this is the headline `cross_validation_px`), per camera, plus the baseline and
   rotation differences of the two halves.

Units: mm, px; angles in degrees in what the user sees, radians inside.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Sequence

import cv2
import numpy as np

from core.stereo.board import Board
from core.camera import CameraModel
from core.stereo.checkerboard import (MIN_PAIRS_TO_CALIBRATE, Coverage, DetectionResult, PairDetection,
                               board_symmetries, coverage, summarize_rejections)
from core.errors import RoboCalError, UsageError
from core.images import load_gray
from core.stereo.rig import StereoRig
from core.task import Monitor
from core.transforms import best_rotation, rotation_angle

DIST_NAMES = ("k1", "k2", "p1", "p2", "k3", "k4", "k5", "k6")
MIN_VIEWS_PER_HALF = 4
_CRITERIA = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 200, 1e-12)
_UNDISTORT_CRITERIA = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 100, 1e-12)


# --------------------------------------------------------------------------- options


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


# --------------------------------------------------------------------------- results


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
    """The numbers of one joint stereo fit."""

    K1: np.ndarray
    D1: np.ndarray
    K2: np.ndarray
    D2: np.ndarray
    R: np.ndarray
    T: np.ndarray                 # (3,) mm
    E: np.ndarray
    F: np.ndarray
    rvecs: np.ndarray             # (V, 3) board poses in the left camera frame
    tvecs: np.ndarray             # (V, 3) mm
    rms_stereo: float
    mono_left: MonoCalibration
    mono_right: MonoCalibration


@dataclass
class ParameterRow:
    """A row of the parameter table: value ± std (std 0 and fixed=True for fixed ones)."""

    group: str        # "left", "right" or "stereo"
    name: str         # "fx", "k1", "baseline", "rx", ...
    value: float
    std: float
    unit: str
    fixed: bool = False

    def text(self) -> str:
        if self.fixed:
            return f"{self.value:.6g} {self.unit} (fixed)".strip()
        return f"{self.value:.6g} ± {self.std:.2g} {self.unit}".strip()


@dataclass
class Rectification:
    """stereoRectify's output and the epipolar error of the matched corners after it."""

    R1: np.ndarray
    R2: np.ndarray
    P1: np.ndarray
    P2: np.ndarray
    Q: np.ndarray
    roi_left: tuple[int, int, int, int]
    roi_right: tuple[int, int, int, int]
    vertical: bool                      # True when the cameras are one above the other
    epipolar_errors: np.ndarray         # (V, N) signed y_left − y_right (x for vertical), px
    epipolar_rms: float
    epipolar_max: float
    rectified_left: np.ndarray          # (V, N, 2) rectified corner positions (for drawing)
    rectified_right: np.ndarray
    image_size: tuple[int, int]
    K1: np.ndarray
    D1: np.ndarray
    K2: np.ndarray
    D2: np.ndarray
    _maps: dict = field(default_factory=dict, init=False, repr=False, compare=False)

    def maps(self, m1type: int = cv2.CV_16SC2):
        """Rectification maps ((map1x, map1y), (map2x, map2y)) for cv2.remap, computed once."""
        if m1type not in self._maps:
            left = cv2.initUndistortRectifyMap(self.K1, self.D1, self.R1, self.P1, self.image_size, m1type)
            right = cv2.initUndistortRectifyMap(self.K2, self.D2, self.R2, self.P2, self.image_size, m1type)
            self._maps[m1type] = (left, right)
        return self._maps[m1type]

    def rectify(self, left: np.ndarray, right: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The rectified pair (a preview: rows of the two images are epipolar lines)."""
        (l1, l2), (r1, r2) = self.maps()
        return (cv2.remap(left, l1, l2, cv2.INTER_LINEAR), cv2.remap(right, r1, r2, cv2.INTER_LINEAR))

    def rectify_files(self, left_path, right_path) -> tuple[np.ndarray, np.ndarray]:
        """Read a pair of image files and rectify it (RoboCalError naming an unreadable file)."""
        images = []
        for path in (left_path, right_path):
            image, why = load_gray(path)
            if image is None:
                raise RoboCalError(f"cannot show this pair: {why}", source=path)
            images.append(image)
        return self.rectify(*images)


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


@dataclass
class StereoCalibrationResult:
    """Everything the stereo calibration page draws and the files hold."""

    rig: StereoRig                      # cameras with 5 coefficients, 8 with the rational model
    image_size: tuple[int, int]
    board: Board
    options: CalibrationOptions
    K1: np.ndarray
    D1: np.ndarray                      # 5 or 8 coefficients (OpenCV order)
    K2: np.ndarray
    D2: np.ndarray
    R: np.ndarray
    T: np.ndarray                       # (3,) mm, X_right = R·X_left + T
    E: np.ndarray
    F: np.ndarray
    rms_left: float
    rms_right: float
    rms_stereo: float
    view_indices: list[int]             # pair index (in the detection list) of each used view
    view_names: list[str]
    object_points: np.ndarray           # (N, 3) mm
    left_points: np.ndarray             # (V, N, 2) px, in the order used
    right_points: np.ndarray
    residuals_left: np.ndarray          # (V, N, 2) observed − projected, px
    residuals_right: np.ndarray
    per_view_rms_left: np.ndarray       # (V,)
    per_view_rms_right: np.ndarray
    per_view_rms: np.ndarray            # (V,) both cameras
    outlier_threshold: float
    outliers: list[int]                 # pair indices flagged as outliers
    rvecs: np.ndarray                   # (V, 3) board poses in the left camera frame
    tvecs: np.ndarray                   # (V, 3) mm
    std: dict[str, float]
    parameters: list[ParameterRow]
    rectification: Rectification
    cross_validation: CrossValidation | None
    mono_left: MonoCalibration
    mono_right: MonoCalibration
    rejected: list[tuple[int, str, str]] = field(default_factory=list)   # (pair index, name, reason)
    excluded: list[int] = field(default_factory=list)                     # pair indices the user removed
    reordered: list[tuple[int, str]] = field(default_factory=list)       # (pair index, what was done)
    coverage: Coverage | None = None
    detections: DetectionResult | None = None
    warnings: list[str] = field(default_factory=list)

    @property
    def epipolar_rms(self) -> float:
        return self.rectification.epipolar_rms

    @property
    def epipolar_max(self) -> float:
        return self.rectification.epipolar_max

    @property
    def baseline_mm(self) -> float:
        return float(np.linalg.norm(self.T))

    @property
    def pairs_used(self) -> int:
        return len(self.view_indices)

    def view_position(self, pair_index: int) -> int:
        """Row of a pair index in the per-view arrays."""
        return self.view_indices.index(pair_index)

    def summary(self) -> dict:
        """The figures of `robocal stereo-calibrate --json` (plain Python types)."""
        def cam(K):
            return {"fx": float(K[0, 0]), "fy": float(K[1, 1]), "cx": float(K[0, 2]), "cy": float(K[1, 2])}
        cv = self.cross_validation
        return _finite({
            "rms_left": self.rms_left, "rms_right": self.rms_right, "rms_stereo": self.rms_stereo,
            "epipolar_rms": self.epipolar_rms, "epipolar_max": self.epipolar_max,
            "left": cam(self.K1), "right": cam(self.K2),
            "baseline_mm": self.baseline_mm,
            "pairs_used": self.pairs_used,
            "pairs_rejected": [{"pair": i + 1, "files": name, "reason": reason}
                               for i, name, reason in self.rejected],
            "pairs_excluded": [i + 1 for i in self.excluded],
            "outliers": [i + 1 for i in self.outliers],
            "cross_validation_px": None if cv is None else cv.rms_observed_px,
            "cross_validation": None if cv is None else cv.to_dict(),
            "image_width": self.image_size[0], "image_height": self.image_size[1],
            "options": self.options.to_dict(),
            "coverage": None if self.coverage is None else self.coverage.to_dict(),
            "warnings": list(self.warnings),
        })


def _finite(value):
    """Plain Python types with non-finite numbers as None (strict JSON)."""
    if isinstance(value, dict):
        return {k: _finite(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_finite(v) for v in value]
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    if isinstance(value, (int, np.integer)):
        return int(value)
    if isinstance(value, (float, np.floating)):
        return float(value) if math.isfinite(value) else None
    return value


# --------------------------------------------------------------------------- entry points


def calibrate_stereo(detections: DetectionResult, options: CalibrationOptions = CalibrationOptions(), *,
                     exclude: Sequence[int] = (), progress=None, cancelled=None) -> StereoCalibrationResult:
    """Calibrate from `core.stereo.checkerboard.detect_pairs` output, without the pairs in `exclude`.

    `exclude` holds pair indices (0-based, as `PairDetection.index`). Raises RoboCalError
    when fewer than `MIN_PAIRS_TO_CALIBRATE` usable pairs remain, naming the rejected files.
    """
    options = options.validate()
    excluded = sorted(set(int(i) for i in exclude))
    known = {p.index for p in detections.pairs}
    unknown = [i for i in excluded if i not in known]
    if unknown:
        raise UsageError(f"cannot exclude pair(s) {', '.join(str(i + 1) for i in unknown)}: "
                         f"there are {len(detections.pairs)} pairs")
    use = [p for p in detections.pairs if p.accepted and p.index not in excluded]
    rejected = [(p.index, p.name, p.reason or "rejected") for p in detections.pairs if not p.accepted]
    if detections.image_size is None or len(use) < MIN_PAIRS_TO_CALIBRATE:
        _raise_too_few(detections.pairs, len(use), excluded)
    result = calibrate_points([p.left.corners for p in use], [p.right.corners for p in use],
                              detections.board, detections.image_size, options,
                              indices=[p.index for p in use], names=[p.name for p in use],
                              progress=progress, cancelled=cancelled, _rejected=rejected,
                              _detections=detections)
    result.excluded = excluded
    result.coverage = coverage([p for p in detections.pairs
                                if p.accepted and p.index in set(result.view_indices)])
    if not result.coverage.enough:
        result.warnings.insert(0, "not enough views for a trusted calibration: "
                               + "; ".join(result.coverage.advice))
    return result


def _raise_too_few(pairs: Sequence[PairDetection], usable: int, excluded: Sequence[int]) -> None:
    n = len(pairs)
    if usable == 0 and not excluded:
        head = f"no usable pair among the {n} pairs" if n > 1 else "the pair is not usable"
    else:
        head = (f"only {usable} usable pair{'s' if usable != 1 else ''} of {n} "
                f"(at least {MIN_PAIRS_TO_CALIBRATE} needed)")
    if excluded:
        head += f", {len(excluded)} excluded by you"
    detail = summarize_rejections(pairs)
    raise RoboCalError(head + (": " + detail if detail else ""),
                       hint="Add pairs with the whole board sharp and visible in both images, "
                            "and check the board size (inner corners) and square size.")


def calibrate_points(left_points: Sequence[np.ndarray], right_points: Sequence[np.ndarray], board: Board,
                     image_size: tuple[int, int], options: CalibrationOptions = CalibrationOptions(), *,
                     indices: Sequence[int] | None = None, names: Sequence[str] | None = None,
                     check_order: bool = True, progress=None, cancelled=None,
                     _rejected: Sequence[tuple[int, str, str]] = (),
                     _detections: DetectionResult | None = None) -> StereoCalibrationResult:
    """Calibrate from corner lists ((N, 2) px per view, in `board.object_points()` order)."""
    options = options.validate()
    monitor = Monitor(progress, cancelled)
    V = len(left_points)
    if len(right_points) != V:
        raise UsageError(f"{V} left views but {len(right_points)} right views")
    indices = list(range(V)) if indices is None else [int(i) for i in indices]
    names = [f"pair {i + 1}" for i in indices] if names is None else list(names)
    rejected = list(_rejected)
    obj = board.object_points().astype(np.float64)
    N = obj.shape[0]
    L = np.array([np.asarray(c, dtype=np.float64).reshape(N, 2) for c in left_points]).reshape(V, N, 2)
    Rp = np.array([np.asarray(c, dtype=np.float64).reshape(N, 2) for c in right_points]).reshape(V, N, 2)
    if V < MIN_PAIRS_TO_CALIBRATE:
        raise RoboCalError(f"only {V} usable pairs (at least {MIN_PAIRS_TO_CALIBRATE} needed)",
                           hint="Add pairs with the whole board visible in both images.")
    image_size = (int(image_size[0]), int(image_size[1]))

    monitor.step(0.02, "calibrating the left camera")
    mono_l = calibrate_mono(obj, L, image_size, options)
    monitor.step(0.12, "calibrating the right camera")
    mono_r = calibrate_mono(obj, Rp, image_size, options)

    reordered: list[tuple[int, str]] = []
    if check_order:
        monitor.step(0.22, "checking the corner order against the stereo geometry")
        choice, bad = _order_consensus(mono_l, mono_r, board)
        syms = board_symmetries(board.cols, board.rows)
        for v, s in enumerate(choice):
            if s > 0 and v not in bad:
                Rp[v] = Rp[v][syms[s][1]]
                reordered.append((indices[v], f"right corners relabelled ({syms[s][0]}) to match the "
                                              f"stereo geometry of the other pairs"))
        if bad:
            for v, why in bad.items():
                rejected.append((indices[v], names[v],
                                 f"{why} (wrong pairing, or the board moved between the two exposures)"))
            keep = [v for v in range(V) if v not in bad]
            if len(keep) < MIN_PAIRS_TO_CALIBRATE:
                raise RoboCalError(
                    f"only {len(keep)} pairs agree on the stereo geometry (at least {MIN_PAIRS_TO_CALIBRATE} "
                    f"needed); disagreeing: {', '.join(names[v] for v in bad)}",
                    hint="Check that the left and right images are taken at the same moment and paired by name.")
            L, Rp = L[keep], Rp[keep]
            indices = [indices[v] for v in keep]
            names = [names[v] for v in keep]
            V = len(keep)
            mono_l = calibrate_mono(obj, L, image_size, options)
            mono_r = calibrate_mono(obj, Rp, image_size, options)
        elif reordered:
            mono_r = calibrate_mono(obj, Rp, image_size, options)

    monitor.step(0.3, "calibrating the stereo pair")
    fit = fit_stereo(obj, L, Rp, image_size, options, mono_l, mono_r)

    monitor.step(0.45, "computing errors and uncertainties")
    res_l, res_r = _residuals(obj, L, Rp, fit)
    pv_l = np.sqrt((res_l ** 2).sum(axis=2).mean(axis=1))
    pv_r = np.sqrt((res_r ** 2).sum(axis=2).mean(axis=1))
    pv = np.sqrt((pv_l ** 2 + pv_r ** 2) / 2.0)
    rms_l = float(np.sqrt((res_l ** 2).sum(axis=2).mean()))
    rms_r = float(np.sqrt((res_r ** 2).sum(axis=2).mean()))
    median = float(np.median(pv))
    sigma = 1.4826 * float(np.median(np.abs(pv - median)))
    threshold = max(median + options.outlier_k * sigma, options.outlier_min_ratio * median)
    outliers = [indices[v] for v in range(V) if pv[v] > threshold]

    std, params = _uncertainty(obj, L, Rp, fit, options, res_l, res_r)

    monitor.step(0.55, "rectifying")
    rect = rectify(fit, L, Rp, image_size, options.rectify_alpha)

    cv = None
    warnings: list[str] = []
    if options.cross_validate:
        if V >= 2 * MIN_VIEWS_PER_HALF:
            cv = cross_validate(obj, L, Rp, image_size, options, indices,
                                monitor=monitor.sub(0.6, 0.98))
        else:
            warnings.append(f"cross-validation needs at least {2 * MIN_VIEWS_PER_HALF} pairs; skipped")
    if cv is not None and cv.max_px > 1.0:
        warnings.append(f"the two halves' models differ by up to {cv.max_px:.1f} px away from where the boards "
                        f"were (RMS {cv.rms_observed_px:.2f} px where they were): add views with the board near "
                        f"the image edges and corners")
    if outliers:
        warnings.append(f"{len(outliers)} pair(s) with a large error (above {threshold:.3f} px): "
                        + ", ".join(names[indices.index(i)] for i in outliers)
                        + " — look at them and exclude them if the detection is wrong")
    centre = -fit.R.T @ fit.T
    if abs(centre[0]) >= abs(centre[1]) and centre[0] < 0:
        warnings.append(f"the right camera sits {abs(centre[0]):.0f} mm to the left of the left camera: "
                        f"are the left and right images swapped?")
    rig = StereoRig(CameraModel(fit.K1, fit.D1, *image_size), CameraModel(fit.K2, fit.D2, *image_size),
                    fit.R, fit.T)
    monitor.step(1.0, "done")
    return StereoCalibrationResult(
        rig=rig, image_size=image_size, board=board, options=options,
        K1=fit.K1, D1=fit.D1, K2=fit.K2, D2=fit.D2, R=fit.R, T=fit.T, E=fit.E, F=fit.F,
        rms_left=rms_l, rms_right=rms_r, rms_stereo=fit.rms_stereo,
        view_indices=indices, view_names=names, object_points=obj, left_points=L, right_points=Rp,
        residuals_left=res_l, residuals_right=res_r,
        per_view_rms_left=pv_l, per_view_rms_right=pv_r, per_view_rms=pv,
        outlier_threshold=threshold, outliers=outliers, rvecs=fit.rvecs, tvecs=fit.tvecs,
        std=std, parameters=params, rectification=rect, cross_validation=cv,
        mono_left=fit.mono_left, mono_right=fit.mono_right,
        rejected=sorted(rejected), reordered=reordered, detections=_detections, warnings=warnings)


# --------------------------------------------------------------------------- fitting


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


def fit_stereo(obj: np.ndarray, L: np.ndarray, Rp: np.ndarray, image_size: tuple[int, int],
               options: CalibrationOptions, mono_l: MonoCalibration | None = None,
               mono_r: MonoCalibration | None = None) -> StereoFit:
    """Per-camera calibration (unless given) then the joint stereo fit."""
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
    return StereoFit(np.asarray(K1, float), _dist_vector(D1, options.n_dist), np.asarray(K2, float),
                     _dist_vector(D2, options.n_dist), np.asarray(R, float).reshape(3, 3),
                     np.asarray(T, float).reshape(3), np.asarray(E, float), np.asarray(F, float),
                     np.array(rvecs).reshape(V, 3), np.array(tvecs).reshape(V, 3), float(rms),
                     mono_l, mono_r)


def _dist_vector(D, n: int) -> np.ndarray:
    d = np.zeros(n)
    given = np.asarray(D, dtype=np.float64).ravel()[:n]
    d[:given.size] = given
    return d


def _cv_message(exc: cv2.error) -> str:
    text = str(exc).strip().splitlines()
    return (text[-1] if text else "OpenCV error").strip()


def _order_consensus(mono_l: MonoCalibration, mono_r: MonoCalibration, board: Board,
                     tolerance_deg: float = 5.0) -> tuple[list[int], dict[int, str]]:
    """For each view, the symmetry of the right labelling that fits the common relative pose.

    Returns (symmetry index per view, {view: why} for views that fit under no labelling).
    Rotation: within `tolerance_deg` of the rotation most views share (the spread on the
    real pairs is below 0.5°; a wrong labelling is off by 90° or 180°). Translation: within
    max(25 % of the baseline, 5 % of the board distance) of the median (spread on the real
    pairs: 3.7 mm at 560 mm) — a right image of another moment usually fails one or both.
    """
    syms = board_symmetries(board.cols, board.rows)
    V = len(mono_l.rvecs)
    Rl = [cv2.Rodrigues(r)[0] for r in mono_l.rvecs]
    Rr = [cv2.Rodrigues(r)[0] for r in mono_r.rvecs]
    # candidates[v][s] = relative rotation if the right labels are permuted by symmetry s
    cands = [[Rr[v] @ Rs @ Rl[v].T for (_, _, Rs, _) in syms] for v in range(V)]

    def angle(A, B):
        return math.degrees(rotation_angle(A.T @ B))

    best_q, best_votes, best_tot = None, -1, np.inf
    for v in range(V):
        for s in range(len(syms)):
            q = cands[v][s]
            dists = [min(angle(q, c) for c in cands[w]) for w in range(V)]
            votes = sum(d < tolerance_deg for d in dists)
            tot = sum(min(d, tolerance_deg) for d in dists)
            if votes > best_votes or (votes == best_votes and tot < best_tot):
                best_q, best_votes, best_tot = q, votes, tot
    choice, bad = [], {}
    trans = np.zeros((V, 3))
    for v in range(V):
        d = [angle(best_q, c) for c in cands[v]]
        s = int(np.argmin(d))
        choice.append(s)
        if d[s] >= tolerance_deg:
            bad[v] = f"left/right board poses disagree with the other pairs by {d[s]:.1f}°"
        _, _, Rs, ts = syms[s]
        t_right = Rr[v] @ (ts * board.square) + mono_r.tvecs[v]      # right pose in the chosen labels
        trans[v] = t_right - cands[v][s] @ mono_l.tvecs[v]
    good = [v for v in range(V) if v not in bad]
    if good:
        median = np.median(trans[good], axis=0)
        depth = float(np.median(mono_l.tvecs[:, 2]))
        limit = max(0.25 * float(np.linalg.norm(median)), 0.05 * abs(depth))
        for v in good:
            off = float(np.linalg.norm(trans[v] - median))
            if off > limit:
                bad[v] = f"left/right board poses disagree with the other pairs by {off:.0f} mm"
    return choice, bad


# --------------------------------------------------------------------------- errors, uncertainty


def _right_poses(fit: StereoFit):
    rvec_rel = cv2.Rodrigues(fit.R)[0]
    for r, t in zip(fit.rvecs, fit.tvecs):
        yield cv2.composeRT(r.reshape(3, 1), t.reshape(3, 1), rvec_rel, fit.T.reshape(3, 1))


def _residuals(obj, L, Rp, fit: StereoFit) -> tuple[np.ndarray, np.ndarray]:
    """Observed − projected corners (V, N, 2) in both images."""
    res_l = np.empty_like(L)
    res_r = np.empty_like(Rp)
    for v, (r, t) in enumerate(zip(fit.rvecs, fit.tvecs)):
        p, _ = cv2.projectPoints(obj, r, t, fit.K1, fit.D1)
        res_l[v] = L[v] - p.reshape(-1, 2)
    for v, comp in enumerate(_right_poses(fit)):
        p, _ = cv2.projectPoints(obj, comp[0], comp[1], fit.K2, fit.D2)
        res_r[v] = Rp[v] - p.reshape(-1, 2)
    return res_l, res_r


def _intrinsic_map(K: np.ndarray, options: CalibrationOptions) -> tuple[np.ndarray, list[str]]:
    """Matrix M with d(fx fy cx cy d...)/d(free parameters), and the free parameters' names."""
    n = 4 + options.n_dist
    cols, names = [], []
    if options.fix_aspect:
        col = np.zeros(n)
        col[0] = K[0, 0] / K[1, 1]
        col[1] = 1.0
        cols.append(col)
        names.append("f")
    else:
        for i, name in ((0, "fx"), (1, "fy")):
            col = np.zeros(n)
            col[i] = 1.0
            cols.append(col)
            names.append(name)
    if not options.fix_principal:
        for i, name in ((2, "cx"), (3, "cy")):
            col = np.zeros(n)
            col[i] = 1.0
            cols.append(col)
            names.append(name)
    for i in options.free_distortion():
        col = np.zeros(n)
        col[4 + i] = 1.0
        cols.append(col)
        names.append(DIST_NAMES[i])
    return np.array(cols).T, names


def _uncertainty(obj, L, Rp, fit: StereoFit, options: CalibrationOptions, res_l, res_r
                 ) -> tuple[dict[str, float], list[ParameterRow]]:
    """Standard deviations from the joint fit's Jacobian (see module notes, step 5)."""
    V, N = L.shape[:2]
    M1, names1 = _intrinsic_map(fit.K1, options)
    M2, names2 = _intrinsic_map(fit.K2, options)
    p1, p2 = M1.shape[1], M2.shape[1]
    refine = options.refine_intrinsics
    n_intr = (p1 + p2) if refine else 0
    n = n_intr + 6 + 6 * V
    m = 2 * 2 * N * V
    J = np.zeros((m, n))
    rvec_rel = cv2.Rodrigues(fit.R)[0]
    rel0 = n_intr
    row = 0
    for v in range(V):
        r, t = fit.rvecs[v].reshape(3, 1), fit.tvecs[v].reshape(3, 1)
        view0 = n_intr + 6 + 6 * v
        _, Jl = cv2.projectPoints(obj, r, t, fit.K1, fit.D1)
        J[row:row + 2 * N, view0:view0 + 6] = Jl[:, :6]
        if refine:
            J[row:row + 2 * N, 0:p1] = Jl[:, 6:] @ M1
        row += 2 * N
        r3, t3, dr3dr1, dr3dt1, dr3dr2, dr3dt2, dt3dr1, dt3dt1, dt3dr2, dt3dt2 = cv2.composeRT(
            r, t, rvec_rel, fit.T.reshape(3, 1))
        _, Jr = cv2.projectPoints(obj, r3, t3, fit.K2, fit.D2)
        Jpose = Jr[:, :6]
        d_view = np.block([[dr3dr1, dr3dt1], [dt3dr1, dt3dt1]])
        d_rel = np.block([[dr3dr2, dr3dt2], [dt3dr2, dt3dt2]])
        J[row:row + 2 * N, view0:view0 + 6] = Jpose @ d_view
        J[row:row + 2 * N, rel0:rel0 + 6] = Jpose @ d_rel
        if refine:
            J[row:row + 2 * N, p1:p1 + p2] = Jr[:, 6:] @ M2
        row += 2 * N
    ssr = float((res_l ** 2).sum() + (res_r ** 2).sum())
    dof = max(m - n, 1)
    sigma2 = ssr / dof
    JtJ = J.T @ J
    try:
        cov = sigma2 * np.linalg.inv(JtJ)
    except np.linalg.LinAlgError:
        cov = sigma2 * np.linalg.pinv(JtJ)
    sd = np.sqrt(np.clip(np.diag(cov), 0.0, None))

    std: dict[str, float] = {}
    rows: list[ParameterRow] = []
    for group, K, D, M, names, off in (("left", fit.K1, fit.D1, M1, names1, 0),
                                        ("right", fit.K2, fit.D2, M2, names2, p1)):
        full_cov = M @ cov[off:off + M.shape[1], off:off + M.shape[1]] @ M.T if refine \
            else np.zeros((M.shape[0], M.shape[0]))
        full_sd = np.sqrt(np.clip(np.diag(full_cov), 0.0, None))
        values = [K[0, 0], K[1, 1], K[0, 2], K[1, 2], *D]
        all_names = ["fx", "fy", "cx", "cy", *DIST_NAMES[:len(D)]]
        free = set(names) | ({"fx", "fy"} if "f" in names else set())
        for i, (name, value) in enumerate(zip(all_names, values)):
            fixed = name not in free or not refine
            unit = "px" if i < 4 else ""
            s = 0.0 if (name not in free) else float(full_sd[i])
            if not refine and name in free:
                mono = fit.mono_left if group == "left" else fit.mono_right
                s = float(mono.std_intrinsics[i]) if i < mono.std_intrinsics.size else 0.0
                fixed = False
            std[f"{name}_{group}"] = s
            rows.append(ParameterRow(group, name, float(value), s, unit, fixed))
    rvec = cv2.Rodrigues(fit.R)[0].ravel()
    for i, name in enumerate(("rx", "ry", "rz")):
        s = math.degrees(float(sd[rel0 + i]))
        std[name] = s
        rows.append(ParameterRow("stereo", name, math.degrees(float(rvec[i])), s, "deg"))
    for i, name in enumerate(("tx", "ty", "tz")):
        s = float(sd[rel0 + 3 + i])
        std[name] = s
        rows.append(ParameterRow("stereo", name, float(fit.T[i]), s, "mm"))
    b = float(np.linalg.norm(fit.T))
    g = fit.T / b if b > 0 else np.zeros(3)
    cov_t = cov[rel0 + 3:rel0 + 6, rel0 + 3:rel0 + 6]
    s_b = float(math.sqrt(max(g @ cov_t @ g, 0.0)))
    std["baseline"] = s_b
    rows.append(ParameterRow("stereo", "baseline", b, s_b, "mm"))
    return std, rows


# --------------------------------------------------------------------------- rectification


def rectify(fit, L: np.ndarray, Rp: np.ndarray, image_size: tuple[int, int], alpha: float = 0.0
            ) -> Rectification:
    """stereoRectify and the epipolar error of the matched corners (see module notes, step 6).

    `fit` is anything with K1, D1, K2, D2, R, T (a StereoFit or a StereoCalibrationResult).
    """
    R1, R2, P1, P2, Q, roi1, roi2 = cv2.stereoRectify(
        fit.K1, fit.D1, fit.K2, fit.D2, image_size, fit.R, fit.T.reshape(3, 1),
        flags=cv2.CALIB_ZERO_DISPARITY, alpha=alpha)
    vertical = abs(P2[1, 3]) > abs(P2[0, 3])
    V, N = L.shape[:2]
    rl = cv2.undistortPoints(L.reshape(-1, 1, 2), fit.K1, fit.D1, R=R1, P=P1,
                             criteria=_UNDISTORT_CRITERIA).reshape(V, N, 2)
    rr = cv2.undistortPoints(Rp.reshape(-1, 1, 2), fit.K2, fit.D2, R=R2, P=P2,
                             criteria=_UNDISTORT_CRITERIA).reshape(V, N, 2)
    axis = 0 if vertical else 1
    err = rl[..., axis] - rr[..., axis]
    return Rectification(R1, R2, P1, P2, Q, tuple(int(x) for x in roi1), tuple(int(x) for x in roi2),
                         bool(vertical), err, float(np.sqrt(np.mean(err ** 2))), float(np.max(np.abs(err))),
                         rl, rr, image_size, fit.K1, fit.D1, fit.K2, fit.D2)


# --------------------------------------------------------------------------- cross-validation


def cross_validate(obj, L: np.ndarray, Rp: np.ndarray, image_size: tuple[int, int],
                   options: CalibrationOptions, indices: Sequence[int] | None = None,
                   monitor: Monitor | None = None) -> CrossValidation:
    """Calibrate the even and the odd views alone and compare the two models (module notes, 7)."""
    monitor = monitor or Monitor()
    V = len(L)
    indices = list(range(V)) if indices is None else list(indices)
    a = list(range(0, V, 2))
    b = list(range(1, V, 2))
    monitor.step(0.0, "cross-validation: first half")
    fa = fit_stereo(obj, L[a], Rp[a], image_size, options)
    monitor.step(0.5, "cross-validation: second half")
    fb = fit_stereo(obj, L[b], Rp[b], image_size, options)
    monitor.step(0.95, "cross-validation: comparing the models")
    left = compare_cameras(fa.K1, fa.D1, fb.K1, fb.D1, image_size, L.reshape(-1, 2), options.cv_grid_step)
    right = compare_cameras(fa.K2, fa.D2, fb.K2, fb.D2, image_size, Rp.reshape(-1, 2), options.cv_grid_step)
    both = np.concatenate([left.diff.ravel(), right.diff.ravel()])
    both = both[np.isfinite(both)]
    obs = np.concatenate([left.diff[left.observed], right.diff[right.observed]])
    obs = obs[np.isfinite(obs)]
    dR = fa.R @ fb.R.T
    rot = math.degrees(rotation_angle(dR))
    return CrossValidation(
        rms_px=float(np.sqrt(np.mean(both ** 2))) if both.size else float("nan"),
        max_px=float(both.max()) if both.size else float("nan"),
        rms_observed_px=float(np.sqrt(np.mean(obs ** 2))) if obs.size else float("nan"),
        left=left, right=right,
        baseline_diff_mm=float(abs(np.linalg.norm(fa.T) - np.linalg.norm(fb.T))),
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
    xy = cv2.undistortPoints(px.reshape(-1, 1, 2), K, D, criteria=_UNDISTORT_CRITERIA).reshape(-1, 2)
    rays = np.concatenate([xy, np.ones((len(xy), 1))], axis=1)
    back, _ = cv2.projectPoints(rays.reshape(-1, 1, 3), np.zeros(3), np.zeros(3), K, D)
    ok = np.all(np.isfinite(rays), axis=1) & (np.linalg.norm(back.reshape(-1, 2) - px, axis=1) < 0.05)
    norm = np.linalg.norm(rays, axis=1, keepdims=True)
    return rays / np.where(norm > 0, norm, 1.0), ok
