"""Kinematic identification: DH parameters, base pose and target offsets from measured points.

The chapter's differential model (eq. 4–10): the position error of a measured point is, to
first order, Δx = J_g·Δg (eq. 5); stacking all points gives Δx = Φ·Δg (eq. 6–7) and the least
squares correction Δg = (ΦᵀΦ)⁻¹Φᵀ·Δx (eq. 9–10), repeated until it converges (Gauss–Newton).
Here, `identify(robot, measurements)` runs the whole step from pieces beside it:

* parameters and the analytic Jacobian: core.kinematics.jacobian; identifiability and
  observability indices: core.kinematics.identifiability;
* one fit (core.identification.fit): the base pose found by a rigid registration
  (Kabsch/Umeyama, SVD) of the nominal model's predictions onto the measurements, so nobody
  types a guess of where the robot stands in the camera frame; two phases — the parameters
  identifiable at the nominal geometry first, then identifiability analysed again at that
  estimate (a real robot has none of the nominal's special values, e.g. a marker exactly on
  the last axis), parameters the data barely determine kept at nominal
  (core.kinematics.identifiability.practical_identifiability) and the fit refined with the final
  set; optional Huber weights by iteratively reweighted least squares, points beyond `outlier_k`
  robust standard deviations flagged as outliers; σ̂² = RSS/(m − p) and the covariance
  σ̂²(ΦᵀWΦ)⁻¹ of the estimated parameters;
* estimation: Levenberg–Marquardt on the column-scaled problem (core.identification.lm); with
  damping λ = 0 a step is exactly eq. (9–10);
* validation: held-out poses (a seeded random fraction) or k-fold cross validation, errors
  before and after calibration, and the deflection terms' test (core.identification.validation);
* the parameter table (core.identification.parameter_table) and the result with its statistics
  (core.identification.result); the calibrated robot file (core.identification.file).

Error statistics ("RMS") are over 3D error norms: rms = sqrt(mean |x_measured − x_model|²).
With isotropic noise σ per axis a perfect model has an expected RMS of σ·√3 on new points.
"Before" means the nominal geometry with the base pose registered to the measurements (the
file's base pose means nothing in the camera frame).
"""
from __future__ import annotations

import math
from datetime import datetime, timezone
from typing import Iterable, Sequence

import numpy as np

from core.errors import UsageError
from core.identification.compliance_selection import AUTO, MODES, OFF, ON, fixed_choice
from core.identification.fit import Fit, coordinate_weights, error_stats, fit_model, linearised, with_joint_values
from core.identification.orientation import (OrientationReport, determined_text, orientation_errors_deg,
                                             with_measured_rotations)
from core.identification.orientation import rms as orientation_rms
from core.identification.prior import EMPIRICAL_BAYES, PriorOptions, PriorReport, Weights, choose_weights, reach_mm
from core.identification.parameter_table import parameter_rows
from core.identification.result import IdentificationResult, ParameterRow
from core.identification.validation import (holdout_validation, kfold_poses, kfold_validation, select_compliance,
                                            split_poses)
from core.kinematics.identifiability import analyse, practical_identifiability
from core.kinematics.jacobian import all_parameters, resolve_names
from core.measurement.file import Measurements, check_against_robot
from core.robot.compliance import DEFAULT_TERMS, Compliance, check_vertical_arm
from core.robot.model import RobotModel
from core.task import Monitor


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
    meas = with_joint_values(meas, robot)
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

    def fit_full(use_compliance: bool, mon: Monitor) -> tuple[Fit, Weights]:
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
        compliance_choice = select_compliance(rigid, robot, train, kw, w_off, w_on, seed, main.sub(0.5, 1.0))
        fit, weights = (fit_on, w_on) if compliance_choice.kept else (fit_off, w_off)
    else:
        fit, weights = fit_full(compliance == ON, main)
        compliance_choice = fixed_choice(compliance, weights.compliance if compliance == ON else None)
    kw.update(prior_weights=weights, compliance=compliance_choice.kept)
    if not compliance_choice.kept:
        robot = rigid
    if holdout is not None:
        validation = holdout_validation(robot, fit.model, train, test, test_ids, fraction=holdout, seed=seed)
    elif kfold is not None:
        validation = kfold_validation(robot, meas, folds, kw, monitor.sub(main_share, 1.0), seed=seed)

    rows, std_int = parameter_rows(fit, robot)
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


def _orientation_report(robot: RobotModel, train: Measurements, fit: Fit, fixed: Sequence[str], with_prior: bool,
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
        alone = practical_identifiability(alone, fit.model, train.Q, train.target, coordinate_weights(train),
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


