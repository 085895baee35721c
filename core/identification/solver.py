"""Kinematic identification: DH parameters, base pose and target offsets from measured points.

The chapter's differential model (eq. 4–10): the position error of a measured point is, to
first order, Δx = J_g·Δg (eq. 5); stacking all points gives Δx = Φ·Δg (eq. 6–7) and the least
squares correction Δg = (ΦᵀΦ)⁻¹Φᵀ·Δx (eq. 9–10), repeated until it converges (Gauss–Newton).
Here:

* parameters and the analytic Jacobian: core.kinematics.jacobian; identifiability and
  observability indices: core.kinematics.identifiability;
* start: the base pose is found by a rigid registration (Kabsch/Umeyama, SVD) of the nominal
  model's predictions onto the measurements, so nobody types a guess of where the robot
  stands in the camera frame;
* estimation: Levenberg–Marquardt on the column-scaled problem (our own short loop rather than
  scipy.optimize.least_squares: it reports every iteration's cost for the GUI, checks Cancel
  between iterations, and updates the base rotation through the exponential map at each step
  so the analytic Jacobian stays exact — scipy can do none of the three). With damping λ = 0
  a step is exactly eq. (9–10);
* two phases: the first fit estimates the parameters identifiable at the nominal geometry;
  identifiability is then analysed again at that estimate (a real robot has none of the
  nominal's special values, e.g. a marker exactly on the last axis), parameters the data
  barely determine are kept at nominal (core.kinematics.identifiability.practical_identifiability), and
  the fit is refined with the final set — the per-iteration records carry the stage;
* optional robust loss: Huber weights by iteratively reweighted least squares; points whose
  error is beyond `outlier_k` robust standard deviations are flagged as outliers;
* uncertainty: σ̂² = RSS/(m − p), covariance σ̂²(ΦᵀWΦ)⁻¹ of the estimated parameters, standard
  deviations, correlation matrix, condition number and observability indices of the final Φ;
* validation: held-out poses (a seeded random fraction) or k-fold cross validation, errors
  before and after calibration.

Error statistics ("RMS") are over 3D error norms: rms = sqrt(mean |x_measured − x_model|²).
With isotropic noise σ per axis a perfect model has an expected RMS of σ·√3 on new points.
"Before" means the nominal geometry with the base pose registered to the measurements (the
file's base pose means nothing in the camera frame).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace
from datetime import datetime, timezone
from pathlib import Path
from typing import Iterable, Sequence

import numpy as np

from core import transforms as tf
from core.kinematics.jacobian import (COMPLIANCE, Parameter, all_parameters, calibration_jacobian, compliance_value,
                                      display_value, predict_points, resolve_names)
from core.errors import RoboCalError, UsageError
from core.identification.prior import (DOMINATED_SHARE, EMPIRICAL_BAYES, PRIOR_DOMINATED, Linearised, PriorOptions,
                                       PriorReport, PriorTerm, Weights, choose_weights, data_share, reach_mm)
from core.kinematics.identifiability import (IDENTIFIED, Identifiability, ObservabilityIndices, analyse,
                                             check_data, column_scales, observability_indices,
                                             practical_identifiability, small_factor)
from core.identification.orientation import (OrientationReport, determined_text, orientation_errors_deg,
                                             orientation_residuals, orientation_weights, require_orientations,
                                             with_measured_rotations)
from core.kinematics.orientation import STRUCTURAL_ROW_SCALE, orientation_jacobian
from core.identification.orientation import rms as orientation_rms
from core.identification.compliance_selection import AUTO, MODES, OFF, ON, ComplianceChoice, cross_validate, decide
from core.identification.compliance_selection import FOLDS as COMPLIANCE_FOLDS
from core.identification.compliance_selection import fixed_choice
from core.identification.lm import levenberg_marquardt
from core.identification.result import (ErrorStats, IdentificationResult, IterationRecord, ParameterRow, Validation,
                                        error_stats_from, merge_stats)
from core.robot.compliance import DEFAULT_TERMS, Compliance, check_vertical_arm
from core.robot.model import RobotModel
from core.measurement.file import Measurements, check_against_robot, read_measurements
from core.robot.file import read_robot, write_robot
from core.task import Monitor

CHI3_MEDIAN = 1.5382              # median of the χ distribution with 3 degrees of freedom
MAX_LENGTH_CORRECTION_MM = 50.0   # beyond max(this, 25 % of the reach) the fit has diverged
MAX_ANGLE_CORRECTION_DEG = 20.0


def error_stats(model: RobotModel, meas: Measurements) -> ErrorStats:
    """Errors of `model` (as it is, base included) on the measured points."""
    meas = _with_q(meas, model)
    vec = meas.xyz - predict_points(model, meas.Q, meas.target)
    return error_stats_from(vec, meas.pose, meas.target)


# -- helpers -------------------------------------------------------------------------------
def _with_q(meas: Measurements, model: RobotModel) -> Measurements:
    if meas.Q is None or meas.Q.shape[1] != model.dof:
        return meas.with_robot(model)
    return meas


def _weights0(meas: Measurements) -> np.ndarray:
    """Per-coordinate weights 1/σ² (N, 3); ones without sigmas."""
    return np.ones((meas.n_points, 3)) if meas.sigma is None else 1.0 / meas.sigma ** 2


def register_base(model: RobotModel, meas: Measurements) -> RobotModel:
    """A copy of `model` whose base pose best maps its predictions onto the measurements."""
    meas = _with_q(meas, model)
    P = predict_points(model, meas.Q, meas.target)
    centred = P - P.mean(axis=0)
    s = np.linalg.svd(centred, compute_uv=False) if len(P) >= 2 else np.zeros(3)
    if len(P) < 3 or s[1] <= 1e-6 * max(s[0], 1e-12):
        raise RoboCalError(
            f"the {len(P)} measured points lie on a line, so the robot's position in the camera "
            f"frame cannot be found", source=meas.source or None,
            hint="Measure more poses, moving several joints (at least 3 points not on a line).")
    T = tf.kabsch(P, meas.xyz)
    out = model.copy()
    out.base = T @ model.base
    return out


def _reach(model: RobotModel) -> float:
    return sum(abs(j.a) + abs(j.d) for j in model.joints) + max(
        (float(np.linalg.norm(t)) for t in model.targets.values()), default=0.0)


def split_poses(pose_ids: Sequence[int], fraction: float, seed: int = 0) -> tuple[list[int], list[int]]:
    """(training, test) pose ids: a seeded random `fraction` of the poses is held out."""
    ids = list(pose_ids)
    if not 0.0 < fraction < 1.0:
        raise UsageError(f"the held-out fraction must be between 0 and 1, got {fraction}")
    n_test = int(round(fraction * len(ids)))
    n_test = min(max(n_test, 1), len(ids) - 1)
    rng = np.random.default_rng(seed)
    test = set(rng.choice(len(ids), size=n_test, replace=False).tolist())
    return [p for k, p in enumerate(ids) if k not in test], [p for k, p in enumerate(ids) if k in test]


def kfold_poses(pose_ids: Sequence[int], folds: int, seed: int = 0) -> list[list[int]]:
    """The pose ids split into `folds` seeded random groups of (nearly) equal size."""
    ids = list(pose_ids)
    if folds < 2 or folds > len(ids):
        raise UsageError(f"k-fold needs 2 ≤ k ≤ number of poses ({len(ids)}), got {folds}")
    order = np.random.default_rng(seed).permutation(len(ids))
    return [[ids[k] for k in sorted(part)] for part in np.array_split(order, folds)]



def _robust_scale(b_points: np.ndarray) -> float:
    """Robust std per axis from whitened point errors (N, 3): median |e| / median(χ₃)."""
    norms = np.linalg.norm(b_points, axis=1)
    s = float(np.median(norms)) / CHI3_MEDIAN
    return s if s > 0 else float(np.sqrt(np.mean(norms ** 2) / 3.0)) or 1e-12


# -- one fit -------------------------------------------------------------------------------
@dataclass
class _Fit:
    model: RobotModel
    initial: RobotModel
    ident: Identifiability
    records: list[IterationRecord]
    converged: bool
    weights: np.ndarray            # (N,) robust point weights
    outliers: list[int]
    sigma_hat: float
    dof: int
    covariance: np.ndarray
    observability: ObservabilityIndices
    prior_weights: Weights = Weights(0.0, 0.0)
    shares: dict[str, float] | None = None     # with a prior: the data share of each free parameter


def _base_fixed(ident_params: Sequence[Parameter], fixed_names: set[str]) -> bool:
    return any(p.group == "base" and p.name in fixed_names for p in ident_params)


def fit_model(robot: RobotModel, meas: Measurements, *, fixed: Iterable[str] = (),
              huber: float | None = None, outlier_k: float = 4.0, max_iterations: int = 100,
              damping: float = 1e-3, prior_weights: Weights | None = None, monitor: Monitor | None = None,
              orientation: bool = False, compliance: bool = False) -> _Fit:
    """Register the base, decide the identifiable parameters, estimate them (LM + optional
    Huber), and compute their covariance. The building block of `identify` (and of k-fold).
    With `prior_weights` (core.identification.prior, not both 0), parameters the data barely
    determine are estimated with the prior toward `robot`'s values instead of being kept at nominal.
    With `orientation`, the measured marker orientations add residuals and the marker's
    orientation on the tool is estimated (core.identification.orientation). With `compliance`, the
    deflection terms of `robot.compliance` are estimated too (ridge weight `prior_weights.compliance`)."""
    monitor = monitor or Monitor()
    if huber is not None and not huber > 0:
        raise UsageError(f"the Huber threshold must be positive, got {huber}")
    meas = _with_q(meas, robot)
    check_against_robot(meas, robot)
    targets = [t for t in robot.targets if t in set(meas.target)]
    turned = require_orientations(meas) if orientation else []
    params = all_parameters(robot, targets, turned, compliance=compliance)
    fixed_names = set(resolve_names(fixed, params, robot))
    monitor.step(0.0, "registering the robot base in the measurement frame")
    initial = robot.copy() if _base_fixed(params, fixed_names) else register_base(robot, meas)
    if turned and not any(p.group == "orientation" and p.name in fixed_names for p in params):
        initial = with_measured_rotations(initial, meas, turned)
    w_o = orientation_weights(meas) if orientation else None
    monitor.step(0.03, "checking which parameters the measurements determine")
    ident = analyse(initial, targets, fixed=fixed_names, params=params)
    prior_weights = prior_weights or Weights(0.0, 0.0)
    prior = None if prior_weights.plain else PriorTerm(robot, prior_weights, reach_mm(robot))
    # with a prior, what the data leave undetermined of the joint parameters the prior determines
    checked = ident if prior is None else replace(ident, free=[p for p in ident.free if not prior.has_row(p)])
    check_data(initial, meas.Q, meas.target, checked, source=meas.source or None,
               orientation_weights=None if w_o is None else np.where(w_o > 0, STRUCTURAL_ROW_SCALE ** 2, 0.0))

    w0 = _weights0(meas)
    records: list[IterationRecord] = []
    lm = dict(records=records, damping=damping, max_iterations=max_iterations, prior=prior, orientation_weights=w_o)
    # Phase 1: the parameters identifiable at the nominal geometry (a safe, reduced set).
    out = levenberg_marquardt(initial, meas, ident.free, w0, monitor=monitor.sub(0.08, 0.45), **lm)
    model, converged = out.model, out.converged
    # Phase 2: re-analyse at the estimate, whose geometry has none of the nominal's special
    # values (marker exactly on an axis, a = 0 exactly …), and drop what the data barely determine.
    for _round in range(3):
        if not converged:
            break
        b1 = meas.xyz - predict_points(model, meas.Q, meas.target)
        dof1 = 3 * meas.n_points - len(ident.free)
        sigma1 = math.sqrt(float(np.sum(w0 * b1 ** 2)) / max(dof1, 1))
        if huber is not None:   # outliers would inflate σ and make good parameters look weak
            sigma1 = min(sigma1, _robust_scale(np.sqrt(w0) * b1))
        ident2 = analyse(model, targets, fixed=fixed_names, params=params)
        if not prior_weights.geometric:
            ident2 = practical_identifiability(ident2, model, meas.Q, meas.target, w0, max(sigma1, 1e-9),
                                               orientation_weights=w_o)
        if ident2.free_names == ident.free_names:
            ident = ident2    # same set; explanations from the analysis at the estimate
            break
        reset = [p for p in ident.free if p.name not in set(ident2.free_names)]
        start = _reset_to(model, initial, reset)
        out = levenberg_marquardt(start, meas, ident2.free, w0, monitor=monitor.sub(0.45, 0.55),
                                  stage="refine", **lm)
        model, converged, ident = out.model, out.converged, ident2
    point_w = np.ones(meas.n_points)
    if huber is not None and converged:
        for rnd in range(1, 21):
            b = np.sqrt(w0) * (meas.xyz - predict_points(model, meas.Q, meas.target))
            u = np.linalg.norm(b, axis=1) / _robust_scale(b)
            new_w = np.minimum(1.0, huber / np.maximum(u, 1e-300))
            change = float(np.max(np.abs(new_w - point_w)))
            point_w = new_w
            if change < 1e-3 and rnd > 1:
                break
            sub = monitor.sub(0.55 + 0.018 * (rnd - 1), 0.55 + 0.018 * rnd)
            out = levenberg_marquardt(model, meas, ident.free, w0 * point_w[:, None], monitor=sub,
                                      stage=f"huber {rnd}", **lm)
            model, converged = out.model, out.converged
    if not converged:
        raise RoboCalError(
            f"the estimation did not converge in {max_iterations} iterations (RMS "
            f"{records[0].rms_mm:.3f} mm at the start, {records[-1].rms_mm:.3f} mm at the end)",
            source=meas.source or None,
            hint="Check that the robot model (DH convention, units) matches the robot and remove "
                 "grossly wrong measurements (or use --huber).")
    _check_blow_up(robot, model, ident.free, meas.source)

    monitor.step(0.92, "uncertainty")
    w = w0 * point_w[:, None]
    b = (np.sqrt(w) * (meas.xyz - predict_points(model, meas.Q, meas.target))).reshape(-1)
    J = np.sqrt(w).reshape(-1)[:, None] * calibration_jacobian(model, meas.Q, meas.target, ident.free)
    if w_o is not None:
        sw_o = np.sqrt(w_o).reshape(-1)
        b = np.concatenate([b, sw_o * orientation_residuals(model, meas).reshape(-1)])
        J = np.vstack([J, sw_o[:, None] * orientation_jacobian(model, meas.Q, meas.target, ident.free)])
    m = J.shape[0] if w_o is None else 3 * meas.n_points + int(np.count_nonzero(w_o))
    J_p = np.zeros((0, J.shape[1])) if prior is None else prior.rows(model, ident.free)[0]
    shares = data_share(J, J_p) if prior is not None else None
    # parameters the prior determines use up less than a degree of freedom each: m − trace(resolution)
    p = float(shares.sum()) if shares is not None else J.shape[1]
    dof = int(round(m - p))
    bw = np.sqrt(w0) * (meas.xyz - predict_points(model, meas.Q, meas.target))
    u = np.linalg.norm(bw, axis=1) / _robust_scale(bw)
    outliers = [int(i) for i in np.flatnonzero(u > outlier_k)]
    if huber is None:
        sigma_hat = math.sqrt(float(b @ b) / (m - p)) if m - p > 0 else math.nan
    else:   # robust fit: the scatter of the points that are not outliers
        inl = np.ones(meas.n_points, bool)
        inl[outliers] = False
        dof_in = 3 * int(inl.sum()) - p
        sigma_hat = math.sqrt(float(np.sum(bw[inl] ** 2)) / dof_in) if dof_in > 0 else math.nan
    J_all = np.vstack([J, J_p])     # the posterior covariance with a prior: σ̂²(ΦᵀWΦ + λP)⁻¹
    D = column_scales(J_all)
    _, s, Vt = np.linalg.svd(small_factor(np.where(np.isfinite(D), J_all / D, 0.0)), full_matrices=False)
    with np.errstate(divide="ignore"):
        inv_s2 = np.where(s > 0, 1.0 / s ** 2, np.inf)
    Dinv = np.where(np.isfinite(D), 1.0 / D, 0.0)
    cov = (sigma_hat ** 2) * (Dinv[:, None] * (Vt.T * inv_s2) @ Vt * Dinv[None, :])
    obs = observability_indices(J, n_points=meas.n_points, scales=column_scales(J))
    monitor.step(1.0, "done")
    return _Fit(model=model, initial=initial, ident=ident, records=records, converged=converged,
                weights=point_w, outliers=outliers, sigma_hat=sigma_hat, dof=dof, covariance=cov,
                observability=obs, prior_weights=prior_weights,
                shares=None if shares is None else dict(zip(ident.free_names, shares.tolist())))


def linearised(fit: _Fit, meas: Measurements) -> Linearised:
    """The fit's whitened Jacobian and residual on `meas` (robust weights included), with the
    orientation rows when the fit estimated the marker's orientation, as `fit_model` stacks them."""
    free = fit.ident.free
    sw = np.sqrt(_weights0(meas) * fit.weights[:, None]).reshape(-1)
    J = sw[:, None] * calibration_jacobian(fit.model, meas.Q, meas.target, free)
    b = sw * (meas.xyz - predict_points(fit.model, meas.Q, meas.target)).reshape(-1)
    if any(p.group == "orientation" for p in free):
        sw_o = np.sqrt(orientation_weights(meas)).reshape(-1)
        J = np.vstack([J, sw_o[:, None] * orientation_jacobian(fit.model, meas.Q, meas.target, free)])
        b = np.concatenate([b, sw_o * orientation_residuals(fit.model, meas).reshape(-1)])
    return Linearised(fit.model, list(free), J, b)


def _reset_to(model: RobotModel, reference: RobotModel, params: Sequence[Parameter]) -> RobotModel:
    """A copy of `model` with the joint and target parameters `params` set back to `reference`."""
    out = model.copy()
    for p in params:
        if p.group == "joint":
            setattr(out.joints[p.joint], p.kind, getattr(reference.joints[p.joint], p.kind))
        elif p.group == "target":
            t = out.targets[p.target].copy()
            t["xyz".index(p.kind)] = reference.targets[p.target]["xyz".index(p.kind)]
            out.targets[p.target] = t
        elif p.group == "orientation" and p.target in reference.target_rotations:
            out.target_rotations[p.target] = reference.target_rotations[p.target].copy()
        elif p.group == COMPLIANCE:
            out.compliance.set(p.joint, p.kind, compliance_value(reference, p))
    return out


def _check_blow_up(nominal: RobotModel, model: RobotModel, free: Sequence[Parameter], source) -> None:
    limit_len = max(MAX_LENGTH_CORRECTION_MM, 0.25 * _reach(nominal))
    for p in free:
        if p.group != "joint":
            continue
        delta = getattr(model.joints[p.joint], p.kind) - getattr(nominal.joints[p.joint], p.kind)
        if p.angular:
            delta = (delta + math.pi) % (2 * math.pi) - math.pi
            bad = abs(math.degrees(delta)) > MAX_ANGLE_CORRECTION_DEG
            shown = f"{math.degrees(delta):+.1f} deg"
        else:
            bad = abs(delta) > limit_len
            shown = f"{delta:+.1f} mm"
        if bad:
            raise RoboCalError(
                f"the estimation diverged: {p.name} moved {shown} from its nominal value, far more "
                f"than a calibration corrects", source=source or None,
                hint="Check that the robot model (DH convention, joint zero positions, units) matches "
                     "the robot that was measured.")


# -- the parameter table -------------------------------------------------------------------
def _rpy_jacobian(R: np.ndarray) -> np.ndarray:
    """∂(roll, pitch, yaw)/∂ω for R ← Exp(ω)·R at ω = 0 (central differences)."""
    h = 1e-7
    E = np.zeros((3, 3))
    for k in range(3):
        w = np.zeros(3)
        w[k] = h
        d = tf.matrix_to_rpy(tf.rot_vec(w) @ R) - tf.matrix_to_rpy(tf.rot_vec(-w) @ R)
        E[:, k] = ((d + np.pi) % (2 * np.pi) - np.pi) / (2 * h)
    return E


def _parameter_rows(fit: _Fit, nominal: RobotModel) -> tuple[list[ParameterRow], np.ndarray]:
    ident, model = fit.ident, fit.model
    free_index = {p.name: k for k, p in enumerate(ident.free)}
    std_int = np.sqrt(np.clip(np.diag(fit.covariance), 0.0, None))
    rot_free = [k for k, p in enumerate(ident.free) if p.group == "base" and len(p.kind) == 2]
    rpy_std = {}
    if rot_free:
        E = _rpy_jacobian(model.base[:3, :3])
        cols = ["xyz".index(ident.free[k].kind[1]) for k in rot_free]
        C = fit.covariance[np.ix_(rot_free, rot_free)]
        Es = E[:, cols]
        var = np.diag(Es @ C @ Es.T)
        rpy_std = {axis: float(np.rad2deg(np.sqrt(max(v, 0.0)))) for axis, v in zip("xyz", var)}
    rows = []
    for prm in ident.params:
        k = free_index.get(prm.name)
        excl = ident.exclusion(prm.name)
        if k is not None:
            if prm.group == "base" and len(prm.kind) == 2:
                std = rpy_std.get(prm.kind[1])
            else:
                std = float(std_int[k] * prm.to_display)
        else:
            std = None
        share = (fit.shares.get(prm.name) if fit.shares is not None and prm.group in ("joint", COMPLIANCE)
                 else None)
        status = IDENTIFIED if k is not None else excl.status
        explanation = "" if excl is None else excl.explanation
        if share is not None and share < DOMINATED_SHARE:
            status = PRIOR_DOMINATED
            explanation = (f"The measurements determine {share:.0%} of {prm.name}; the prior toward its "
                           f"nominal value determines the rest.")
        rows.append(ParameterRow(
            name=prm.name, group=prm.group, kind=prm.kind, unit=prm.unit,
            nominal=display_value(nominal, prm), initial=display_value(fit.initial, prm),
            identified=display_value(model, prm), std=std, identifiable=k is not None,
            status=status, explanation=explanation,
            partners=() if excl is None else excl.partners, data_share=share))
    return rows, std_int


# -- the whole step ------------------------------------------------------------------------
def identify(robot: RobotModel, meas: Measurements, *, fixed: Iterable[str] = (),
             huber: float | None = None, holdout: float | None = None, kfold: int | None = None,
             seed: int = 0, outlier_k: float = 4.0, max_iterations: int = 100, damping: float = 1e-3,
             prior: PriorOptions | None = None, orientation: bool = False, compliance: str = OFF,
             payload_kg: float | None = None, progress=None, cancelled=None) -> IdentificationResult:
    """Identify the robot's geometry from measured points.

    `fixed`: parameter names kept at their nominal value (`J2.a`, `base.rz`, `marker.x`).
    `huber`: Huber threshold in robust standard deviations of a point's error (e.g. 3), or None.
    `holdout`: fraction of the poses held out for validation; the returned model is fitted on
    the others (what is validated is what is written). `kfold`: k-fold cross validation; the
    returned model is fitted on all poses and every pose is predicted once by a model that did
    not see it. `orientation`: the measured marker orientations (file columns rx … srz) add
    residuals and the marker's orientation on the tool is estimated as `<target>.rx/.ry/.rz`
    (core.identification.orientation). `prior`: a prior toward the nominal DH values instead of
    keeping weakly determined parameters at nominal (core.identification.prior); its weights,
    unless given, are estimated by empirical Bayes from the poses the returned model is fitted on
    (and kept for every fold). `compliance`: the gravity-shaped deflection terms
    (core.robot.compliance) "off" (geometry only; a model's own terms are dropped), "on"
    (estimated, ridge weight by empirical Bayes), or "auto" (kept only when cross validation over
    poses shows a gain: core.identification.compliance_selection). `payload_kg`: the mass mounted
    during calibration, recorded beside the result. Raises RoboCalError for bad data, Cancelled on
    cancel."""
    if compliance not in MODES:
        raise UsageError(f"unknown deflection choice '{compliance}'", hint=f"Use one of {', '.join(MODES)}.")
    if payload_kg is not None and not (math.isfinite(payload_kg) and payload_kg >= 0):
        raise UsageError(f"the payload must be a mass of 0 kg or more, got {payload_kg}")
    if holdout is not None and kfold is not None:
        raise UsageError("use either a held-out fraction or k-fold cross validation, not both")
    if compliance != OFF:
        check_vertical_arm(robot, field="--compliance")
    monitor = Monitor(progress, cancelled)
    input_robot = robot
    robot, unknown = with_unknown_targets(robot, meas)
    meas = _with_q(meas, robot)
    check_against_robot(meas, robot)
    fixed = list(fixed)
    kw = dict(fixed=fixed, huber=huber, outlier_k=outlier_k, max_iterations=max_iterations, damping=damping,
              orientation=orientation)
    robot, rigid = _compliance_robots(robot, compliance)
    validation = None
    train = meas
    if holdout is not None:
        train_ids, test_ids = split_poses(meas.pose_ids, holdout, seed)
        train, test = meas.select_poses(train_ids), meas.select_poses(test_ids)
    elif kfold is not None:
        folds = kfold_poses(meas.pose_ids, kfold, seed)
    search_geometry = ["length", "angle"] if prior is not None and prior.weight is None else []
    given = prior.weight if prior is not None and prior.weight is not None else 0.0
    start = Weights(given, given)
    expensive = bool(search_geometry) or compliance != OFF
    main_share = 1.0 if kfold is None else (0.6 if expensive else 1.0 / (kfold + 1))
    main = monitor.sub(0.0, main_share)

    def fit_full(use_compliance: bool, mon: Monitor) -> tuple[_Fit, Weights]:
        """The fit on the training poses, its prior's (and ridge's) weights by empirical Bayes."""
        model = robot if use_compliance else rigid
        search = search_geometry + (["compliance"] if use_compliance else [])
        if not search:
            return fit_model(model, train, monitor=mon, prior_weights=start, **kw), start
        fits = {}

        def fit_at(weights, m):
            fits[weights] = fit_model(model, train, monitor=m, prior_weights=weights,
                                      compliance=use_compliance, **kw)
            return linearised(fits[weights], train)
        chosen = choose_weights(fit_at, model, monitor=mon, search=search, start=start)
        return fits[chosen.weights], chosen.weights

    if compliance == AUTO:
        fit_off, w_off = fit_full(False, main.sub(0.0, 0.2))
        fit_on, w_on = fit_full(True, main.sub(0.2, 0.5))
        compliance_choice = _select_compliance(rigid, robot, train, kw, w_off, w_on, seed, main.sub(0.5, 1.0))
        fit, weights = (fit_on, w_on) if compliance_choice.kept else (fit_off, w_off)
    else:
        fit, weights = fit_full(compliance == ON, main)
        compliance_choice = fixed_choice(compliance, weights.compliance if compliance == ON else None)
    kw.update(prior_weights=weights, compliance=compliance_choice.kept)
    if not compliance_choice.kept:
        robot = rigid
    if holdout is not None:
        before = error_stats(register_base(robot, train), test)
        validation = Validation("holdout", before=before, after=error_stats(fit.model, test),
                                test_poses=[int(p) for p in test_ids], fraction=float(holdout), seed=seed)
    elif kfold is not None:
        befores, afters, rms = [], [], []
        rest = monitor.sub(main_share, 1.0)
        for k, test_ids in enumerate(folds):
            sub = rest.sub(k / kfold, (k + 1) / kfold)
            sub.step(0.0, f"cross validation: fold {k + 1} of {kfold}")
            tr = meas.select_poses([p for p in meas.pose_ids if p not in set(test_ids)])
            te = meas.select_poses(test_ids)
            try:
                f = fit_model(robot, tr, monitor=sub, **kw)
            except RoboCalError as exc:
                raise RoboCalError(f"cross validation fold {k + 1} of {kfold}: {exc.problem}",
                                   source=exc.source, hint=exc.hint or
                                   "Use fewer folds or measure more poses.") from exc
            befores.append(error_stats(register_base(robot, tr), te))
            afters.append(error_stats(f.model, te))
            rms.append(afters[-1].rms_mm)
        validation = Validation("kfold", before=merge_stats(befores), after=merge_stats(afters),
                                test_poses=[int(p) for p in meas.pose_ids], folds=int(kfold), seed=seed,
                                fold_rms_mm=rms)

    rows, std_int = _parameter_rows(fit, robot)
    orientation_report = (_orientation_report(robot, train, fit, fixed, prior is not None, rows,
                                              test if holdout is not None else None) if orientation else None)
    cov = fit.covariance
    with np.errstate(invalid="ignore", divide="ignore"):
        corr = cov / np.outer(std_int, std_int)
    corr = np.where(np.isfinite(corr), corr, 0.0)
    np.fill_diagonal(corr, 1.0)
    before = error_stats(fit.initial, train)
    after = error_stats(fit.model, train)
    warnings = []
    if unknown:
        warnings.append(f"target(s) {', '.join(unknown)} are not in the robot file: their offsets on the tool "
                        f"were estimated from a start at the tool origin")
    unmeasured = [t for t in robot.targets if t not in set(meas.target)]
    if unmeasured:
        warnings.append(f"target(s) {', '.join(unmeasured)} were not measured: their offsets keep the "
                        f"nominal values, and errors of the last joint that the measured targets absorb "
                        f"are not corrected for them")
    if fit.outliers:
        warnings.append(f"{len(fit.outliers)} point(s) have errors beyond {outlier_k:g} robust standard "
                        f"deviations (outliers)")
    if fit.dof < len(fit.ident.free):
        warnings.append(f"few measurements for {len(fit.ident.free)} parameters ({fit.dof} degrees of "
                        f"freedom left): the uncertainties are themselves uncertain; measure more poses")
    if compliance == OFF and rigid is not input_robot and input_robot.compliance is not None:
        warnings.append("the robot file's deflection terms were dropped (geometry only was asked for)")
    prior_report = None
    if prior is not None:
        prior_report = PriorReport(
            weights=fit.prior_weights, reach_mm=reach_mm(robot), sigma_hat=fit.sigma_hat,
            chosen_by=EMPIRICAL_BAYES if search_geometry else "given",
            shares={r.name: r.data_share for r in rows if r.data_share is not None})
    model = fit.model.copy()
    result = IdentificationResult(
        model=model, nominal=robot, initial=fit.initial, identifiability=fit.ident, parameters=rows,
        estimated=fit.ident.free_names, estimate_std=std_int, covariance=cov, correlation=corr,
        iterations=fit.records, converged=fit.converged, sigma_hat=fit.sigma_hat, dof=fit.dof,
        observability=fit.observability, before=before, after=after, weights=fit.weights,
        outliers=fit.outliers, validation=validation, measurements_source=meas.source,
        n_poses=train.n_poses, n_points=train.n_points, huber=huber,
        date=datetime.now(timezone.utc).replace(microsecond=0).isoformat(), warnings=warnings,
        weighted=train.sigma is not None, prior=prior_report, orientation=orientation_report,
        compliance=compliance_choice, payload_kg=payload_kg)
    model.calibration = result.calibration_section()
    return result


def _compliance_robots(robot: RobotModel, mode: str) -> tuple[RobotModel, RobotModel]:
    """(the robot with the deflection terms to estimate, the rigid robot). For OFF both are rigid;
    otherwise the robot's shape is checked (a vertical articulated arm) and the default terms are
    added to the ones it has (at zero)."""
    rigid = robot
    if robot.compliance is not None:
        rigid = robot.copy()
        rigid.compliance = None
    if mode == OFF:
        return rigid, rigid
    with_terms = robot.copy()
    with_terms.compliance = (Compliance.zero(robot.dof) if robot.compliance is None
                             else robot.compliance.with_terms(DEFAULT_TERMS))
    return with_terms, rigid


def _select_compliance(rigid: RobotModel, robot: RobotModel, train: Measurements, kw: dict, w_off: Weights,
                       w_on: Weights, seed: int, monitor: Monitor) -> ComplianceChoice:
    """Cross validation grouped by pose of the fits without and with the deflection terms (their
    weights kept), decided by the one-standard-error rule."""
    n = len(train.pose_ids)
    try:
        folds = kfold_poses(train.pose_ids, min(COMPLIANCE_FOLDS, n), seed)
        off, on = cross_validate(
            lambda tr, m: fit_model(rigid, tr, monitor=m, prior_weights=w_off, **kw).model,
            lambda tr, m: fit_model(robot, tr, monitor=m, prior_weights=w_on, compliance=True, **kw).model,
            train, folds, monitor=monitor)
    except (RoboCalError, UsageError) as exc:
        return ComplianceChoice(AUTO, False, f"Too few poses to test the deflection terms ({n}: "
                                f"{exc.problem}); geometry only.")
    if len(off) < 3:
        return ComplianceChoice(AUTO, False, f"Too few poses to test the deflection terms ({len(off)} could be "
                                f"predicted); geometry only.")
    return decide(off, on, len(folds), w_on.compliance)


def _orientation_report(robot: RobotModel, train: Measurements, fit: _Fit, fixed: Sequence[str], with_prior: bool,
                        rows: list[ParameterRow], test: Measurements | None) -> OrientationReport:
    """Orientation errors, and which parameters only the orientations determine: those estimated
    here that the points alone (the same analysis without orientation rows) leave out. The
    explanations of their rows say so."""
    targets = fit.ident.targets
    turned = [p.target for p in fit.ident.params if p.group == "orientation"]
    turned = list(dict.fromkeys(turned))
    params = all_parameters(robot, targets)
    fixed_pos = []
    for name in fixed:                 # the user's fixed names that exist without orientation
        try:
            fixed_pos += resolve_names([name], params, robot)
        except UsageError:
            pass
    alone = analyse(fit.model, targets, fixed=fixed_pos, params=params)
    if not with_prior:
        alone = practical_identifiability(alone, fit.model, train.Q, train.target, _weights0(train),
                                          max(fit.sigma_hat, 1e-9))
    determined = [n for n in fit.ident.free_names if n in {p.name for p in alone.params} and n not in set(alone.free_names)]
    for r in rows:
        if r.name in determined:
            r.explanation = determined_text(r.name)
    start = with_measured_rotations(fit.initial, train, turned)
    report = OrientationReport(targets=turned, n_points=int(train.has_orientation.sum()),
                               rms_before_deg=orientation_rms(orientation_errors_deg(start, train)),
                               rms_after_deg=orientation_rms(orientation_errors_deg(fit.model, train)),
                               determined=determined)
    if test is not None and test.has_orientation.any():
        report.holdout_rms_before_deg = orientation_rms(orientation_errors_deg(start, test))
        report.holdout_rms_after_deg = orientation_rms(orientation_errors_deg(fit.model, test))
    return report


def with_unknown_targets(robot: RobotModel, meas: Measurements) -> tuple[RobotModel, list[str]]:
    """The robot with every target the measurements name but the robot file lacks (laser-tracker
    reflectors whose offsets nobody measured) added at the tool origin, where identification
    starts its estimate; and their names. The robot itself is not changed."""
    unknown = [t for t in meas.target_names if t not in robot.targets]
    if not unknown:
        return robot, []
    robot = robot.copy()
    for name in unknown:
        robot.targets[name] = np.zeros(3)
    return robot, unknown


def write_calibrated_model(result: IdentificationResult, path: str | Path) -> Path:
    """Write the calibrated robot file (robot format + `calibration` section) atomically."""
    model = result.model.copy()
    model.calibration = result.calibration_section()
    return write_robot(model, path)


def identify_files(robot_path: str | Path, measurements_path: str | Path, out_path: str | Path | None = None,
                   **options) -> IdentificationResult:
    """File to result: read the robot and the measurements, identify, and (with `out_path`)
    write the calibrated model — only after everything succeeded."""
    robot = read_robot(robot_path)
    meas = read_measurements(measurements_path, robot)
    result = identify(robot, meas, **options)
    if out_path is not None:
        write_calibrated_model(result, out_path)
    return result


def evaluate(robot: RobotModel, meas: Measurements, *, register: bool = False) -> ErrorStats:
    """Errors of a model against measurements; with `register`, the base pose is first fitted
    by rigid registration (for a nominal model whose base is not known in the camera frame)."""
    meas = _with_q(meas, robot)
    check_against_robot(meas, robot)
    return error_stats(register_base(robot, meas) if register else robot, meas)
