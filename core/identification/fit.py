"""One fit of a robot model to measured points, and the errors of a model on them.

`fit_model` registers the base (Kabsch/Umeyama on the nominal model's predictions, so nobody
types where the robot stands in the camera frame), decides the identifiable parameters, estimates
them in two phases (those identifiable at the nominal geometry, then again at the estimate,
dropping what the data barely determine), with optional Huber reweighting, and computes their
covariance σ̂²(ΦᵀWΦ)⁻¹. It is the building block of `core.identification.solver.identify`, of its
validation folds and of the prior's and the deflection terms' weight searches.

`error_stats` and `evaluate`: 3D error norms of a model on measured points (mm); "before" a
calibration means the nominal geometry with the base pose registered to the measurements.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Iterable, Sequence

import numpy as np

from core import transforms as tf
from core.errors import RoboCalError, UsageError
from core.identification.lm import levenberg_marquardt
from core.identification.orientation import (orientation_residuals, orientation_weights, require_orientations,
                                             with_measured_rotations)
from core.identification.prior import Linearised, PriorTerm, Weights, data_share, reach_mm
from core.identification.result import ErrorStats, IterationRecord, error_stats_from
from core.kinematics.identifiability import (Identifiability, ObservabilityIndices, analyse, check_data,
                                             column_scales, observability_indices, practical_identifiability,
                                             small_factor)
from core.kinematics.jacobian import (COMPLIANCE, Parameter, all_parameters, calibration_jacobian, compliance_value,
                                      predict_points, resolve_names)
from core.kinematics.orientation import STRUCTURAL_ROW_SCALE, orientation_jacobian
from core.measurement.file import Measurements, check_against_robot
from core.robot.model import RobotModel
from core.task import Monitor

CHI3_MEDIAN = 1.5382              # median of the χ distribution with 3 degrees of freedom
MAX_LENGTH_CORRECTION_MM = 50.0   # beyond max(this, 25 % of the reach) the fit has diverged
MAX_ANGLE_CORRECTION_DEG = 20.0


def with_joint_values(meas: Measurements, model: RobotModel) -> Measurements:
    """`meas` with its joint values in `model`'s internal units (rad / mm), converted from the
    file's when they are not there yet."""
    if meas.Q is None or meas.Q.shape[1] != model.dof:
        return meas.with_robot(model)
    return meas


def coordinate_weights(meas: Measurements) -> np.ndarray:
    """Per-coordinate weights 1/σ² (N, 3); ones without sigmas."""
    return np.ones((meas.n_points, 3)) if meas.sigma is None else 1.0 / meas.sigma ** 2


def register_base(model: RobotModel, meas: Measurements) -> RobotModel:
    """A copy of `model` whose base pose best maps its predictions onto the measurements."""
    meas = with_joint_values(meas, model)
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


def error_stats(model: RobotModel, meas: Measurements) -> ErrorStats:
    """Errors of `model` (as it is, base included) on the measured points."""
    meas = with_joint_values(meas, model)
    vec = meas.xyz - predict_points(model, meas.Q, meas.target)
    return error_stats_from(vec, meas.pose, meas.target)


def evaluate(robot: RobotModel, meas: Measurements, *, register: bool = False) -> ErrorStats:
    """Errors of a model against measurements; with `register`, the base pose is first fitted
    by rigid registration (for a nominal model whose base is not known in the camera frame)."""
    meas = with_joint_values(meas, robot)
    check_against_robot(meas, robot)
    return error_stats(register_base(robot, meas) if register else robot, meas)


def _reach(model: RobotModel) -> float:
    return sum(abs(j.a) + abs(j.d) for j in model.joints) + max(
        (float(np.linalg.norm(t)) for t in model.targets.values()), default=0.0)


def _robust_scale(b_points: np.ndarray) -> float:
    """Robust std per axis from whitened point errors (N, 3): median |e| / median(χ₃)."""
    norms = np.linalg.norm(b_points, axis=1)
    s = float(np.median(norms)) / CHI3_MEDIAN
    return s if s > 0 else float(np.sqrt(np.mean(norms ** 2) / 3.0)) or 1e-12


@dataclass
class Fit:
    """What `fit_model` estimated, before it becomes an IdentificationResult (internal units)."""

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
              orientation: bool = False, compliance: bool = False) -> Fit:
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
    meas = with_joint_values(meas, robot)
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

    w0 = coordinate_weights(meas)
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
    return Fit(model=model, initial=initial, ident=ident, records=records, converged=converged,
                weights=point_w, outliers=outliers, sigma_hat=sigma_hat, dof=dof, covariance=cov,
                observability=obs, prior_weights=prior_weights,
                shares=None if shares is None else dict(zip(ident.free_names, shares.tolist())))


def linearised(fit: Fit, meas: Measurements) -> Linearised:
    """The fit's whitened Jacobian and residual on `meas` (robust weights included), with the
    orientation rows when the fit estimated the marker's orientation, as `fit_model` stacks them."""
    free = fit.ident.free
    sw = np.sqrt(coordinate_weights(meas) * fit.weights[:, None]).reshape(-1)
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
