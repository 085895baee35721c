"""Stereo calibration from checkerboard corners: intrinsics, distortion, extrinsics,
rectification, per-view and per-corner errors, uncertainty and cross-validation.

Steps (`calibrate_stereo` for detections, `calibrate_points` for bare corner lists):

1. Each camera alone (core.stereo.fit.calibrate_mono, the model of `CalibrationOptions`).
2. Corner order against the stereo geometry: for every pair, the relative pose
   R_i = R_right,i · R_left,iᵀ follows from the two board poses; it must be the same for
   all pairs. Each pair's right labelling is tried under every board symmetry
   (`core.stereo.corner_order.board_symmetries`); the relative rotation shared by most pairs wins,
   pairs are relabelled to agree with it, and a pair that agrees under no labelling
   (wrong pairing, board moved between the two exposures) is dropped with a reason.
3. Both cameras together (core.stereo.fit.fit_stereo): the joint fit, its residuals and
   its rectification.
4. Per-view RMS and automatic outlier flags: a view is flagged when its stereo RMS exceeds
   median + k·σ, σ = 1.4826·MAD (a robust standard deviation, so that the outliers
   themselves do not hide), k = 3, and also exceeds twice the median. (The floor matters on
   clean data: rendered pairs have per-view RMS 0.022–0.047 px, MAD-σ 0.003 px; oblique
   views are a little noisier but not wrong. On the real pairs the floor is 0.29 px and
   pair 15, 0.30 px, is flagged.) Flagged views are only flagged;
   `calibrate_stereo(..., exclude=[...])` recalibrates without the views the user removes.
5. Standard deviations of all parameters (core.stereo.uncertainty).
6. The epipolar error of the matched corners after rectification
   (core.stereo.rectification.epipolar_errors).
7. Cross-validation of two halves of the views (core.stereo.cross_validation).

Units: mm, px; angles in degrees in what the user sees, radians inside.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Sequence

import cv2
import numpy as np

from core.errors import RoboCalError, UsageError
from core.files import strict_json
from core.stereo.board import Board
from core.stereo.screening import DetectionResult, summarize_rejections
from core.stereo.coverage import MIN_PAIRS_TO_CALIBRATE, Coverage, coverage
from core.stereo.detection import PairDetection
from core.stereo.corner_order import board_symmetries
from core.stereo.cross_validation import MIN_VIEWS_PER_HALF, CrossValidation, cross_validate
from core.stereo.file import StereoFile
from core.stereo.fit import CalibrationOptions, MonoCalibration, StereoFit, calibrate_mono, fit_stereo
from core.stereo.rectification import EpipolarErrors, StereoRectification, epipolar_errors
from core.stereo.uncertainty import CameraParameterRow, parameter_uncertainty
from core.task import Monitor
from core.transforms import rotation_angle


@dataclass
class StereoCalibrationResult:
    """Everything the stereo calibration page draws and the files hold.

    The calibrated pair itself (K1 … F, the rectification matrices, the RMS errors, the board)
    is `file`, the StereoFile that stereo.yaml holds; `fit` adds the board poses, the
    residuals and the per-camera fits."""

    fit: StereoFit
    options: CalibrationOptions
    view_indices: list[int]             # pair index (in the detection list) of each used view
    view_names: list[str]
    object_points: np.ndarray           # (N, 3) mm
    left_points: np.ndarray             # (V, N, 2) px, in the order used
    right_points: np.ndarray
    per_view_rms_left: np.ndarray       # (V,)
    per_view_rms_right: np.ndarray
    per_view_rms: np.ndarray            # (V,) both cameras
    outlier_threshold: float
    outliers: list[int]                 # pair indices flagged as outliers
    std: dict[str, float]
    parameters: list[CameraParameterRow]
    rectification: StereoRectification
    epipolar: EpipolarErrors
    cross_validation: CrossValidation | None
    rejected: list[tuple[int, str, str]] = field(default_factory=list)   # (pair index, name, reason)
    excluded: list[int] = field(default_factory=list)                     # pair indices the user removed
    reordered: list[tuple[int, str]] = field(default_factory=list)       # (pair index, what was done)
    coverage: Coverage | None = None
    detections: DetectionResult | None = None
    warnings: list[str] = field(default_factory=list)
    covariance: np.ndarray | None = None    # (14, 14) of file.TRIANGULATION_PARAMETERS: px, deg, mm

    @property
    def file(self) -> StereoFile:
        return self.fit.file

    @property
    def cameras_look_swapped(self) -> bool:
        """The right camera came out to the left of the left one: the images are likely swapped."""
        return right_camera_to_the_left_mm(self.file) is not None

    @property
    def epipolar_rms(self) -> float:
        return self.epipolar.rms

    @property
    def epipolar_max(self) -> float:
        return self.epipolar.max

    @property
    def baseline_mm(self) -> float:
        return self.file.baseline_mm

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
        f = self.file
        return strict_json({
            "rms_left": f.rms_left, "rms_right": f.rms_right, "rms_stereo": f.rms_stereo,
            "epipolar_rms": self.epipolar_rms, "epipolar_max": self.epipolar_max,
            "left": cam(f.K1), "right": cam(f.K2),
            "baseline_mm": self.baseline_mm,
            "pairs_used": self.pairs_used,
            "pairs_rejected": [{"pair": i + 1, "files": name, "reason": reason}
                               for i, name, reason in self.rejected],
            "pairs_excluded": [i + 1 for i in self.excluded],
            "outliers": [i + 1 for i in self.outliers],
            "cross_validation_px": None if cv is None else cv.rms_observed_px,
            "cross_validation": None if cv is None else cv.to_dict(),
            "image_width": f.image_size[0], "image_height": f.image_size[1],
            "options": self.options.to_dict(),
            "coverage": None if self.coverage is None else self.coverage.to_dict(),
            "warnings": list(self.warnings),
        })


def calibrate_stereo(detections: DetectionResult, options: CalibrationOptions = CalibrationOptions(), *,
                     exclude: Sequence[int] = (), progress=None, cancelled=None) -> StereoCalibrationResult:
    """Calibrate from `core.stereo.screening.detect_pairs` output, without the pairs in `exclude`.

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
    fit = fit_stereo(board, L, Rp, image_size, options, mono_l, mono_r)

    monitor.step(0.45, "computing errors and uncertainties")
    pv_l = np.sqrt((fit.residuals_left ** 2).sum(axis=2).mean(axis=1))
    pv_r = np.sqrt((fit.residuals_right ** 2).sum(axis=2).mean(axis=1))
    pv = np.sqrt((pv_l ** 2 + pv_r ** 2) / 2.0)
    median = float(np.median(pv))
    sigma = 1.4826 * float(np.median(np.abs(pv - median)))
    threshold = max(median + options.outlier_k * sigma, options.outlier_min_ratio * median)
    outliers = [indices[v] for v in range(V) if pv[v] > threshold]

    std, params, covariance = parameter_uncertainty(obj, fit, options)

    monitor.step(0.55, "rectifying")
    rect = StereoRectification.from_calibration(fit.file, for_location=False)
    epipolar = epipolar_errors(rect, L, Rp)
    fit.file.extras["epipolar_rms"] = float(epipolar.rms)

    cv = None
    warnings: list[str] = []
    if options.cross_validate:
        if V >= 2 * MIN_VIEWS_PER_HALF:
            cv = cross_validate(board, L, Rp, image_size, options, indices,
                                monitor=monitor.sub(0.6, 0.98))
            fit.file.extras["cross_validation_px"] = float(cv.rms_observed_px)
        else:
            warnings.append(f"cross-validation needs at least {2 * MIN_VIEWS_PER_HALF} pairs; skipped")
    warnings += _warnings(fit.file, cv, outliers, threshold, [names[indices.index(i)] for i in outliers])
    monitor.step(1.0, "done")
    return StereoCalibrationResult(
        fit=fit, options=options,
        view_indices=indices, view_names=names, object_points=obj, left_points=L, right_points=Rp,
        per_view_rms_left=pv_l, per_view_rms_right=pv_r, per_view_rms=pv,
        outlier_threshold=threshold, outliers=outliers,
        std=std, parameters=params, covariance=covariance, rectification=rect, epipolar=epipolar, cross_validation=cv,
        rejected=sorted(rejected), reordered=reordered, detections=_detections, warnings=warnings)


def _warnings(pair: StereoFile, cv: CrossValidation | None, outliers: list[int], threshold: float,
              outlier_names: list[str]) -> list[str]:
    """What the user should look at: extrapolation, outliers, swapped images, the rational model."""
    warnings = []
    if cv is not None and cv.max_px > 1.0:
        warnings.append(f"the two halves' models differ by up to {cv.max_px:.1f} px away from where the boards "
                        f"were (RMS {cv.rms_observed_px:.2f} px where they were): add views with the board near "
                        f"the image edges and corners")
    if outliers:
        warnings.append(f"{len(outliers)} pair(s) with a large error (above {threshold:.3f} px): "
                        + ", ".join(outlier_names)
                        + " — look at them and exclude them if the detection is wrong")
    swapped = right_camera_to_the_left_mm(pair)
    if swapped is not None:
        warnings.append(f"the right camera sits {swapped:.0f} mm to the left of the left camera: "
                        f"are the left and right images swapped?")
    return warnings


def right_camera_to_the_left_mm(pair: StereoFile) -> float | None:
    """How far (mm) the right camera's centre sits to the left of the left camera (along the
    left camera's x) when that is the larger offset of a horizontal rig — the sign of images
    given to the wrong cameras —, else None."""
    centre = -pair.R.T @ pair.T
    if abs(centre[0]) >= abs(centre[1]) and centre[0] < 0:
        return float(abs(centre[0]))
    return None


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

