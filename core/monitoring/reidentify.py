"""Re-identification of what changed, from a few poses, with the previous calibration as a prior.

The parameters of the previous calibration keep their estimate and covariance C as a Gaussian
prior, except the changed set K, which is free (the limit of an infinite prior variance on K:
the prior on the others is the marginal of C over them). Gauss–Newton minimises

    Σ |x_measured − x_model|² / σ²  +  δ_Uᵀ·C_UU⁻¹·δ_U

over the corrections δ of all those parameters (δ_U those of the unchanged ones), so that
the new poses mostly move K and the unchanged parameters only as far as the data ask; σ is
per point (`noise_scale`): the check's points count with the noise the proposal gave them
(`measured_scale` below), so the fit weighs them as the poses were chosen for. The
posterior covariance (ΦᵀΦ/σ² + prior)⁻¹ is written into the new calibrated file, so the next
checks take their limits from it.

The result is refused when the poses cannot determine K (its Jacobian on them is rank
deficient), or when K alone leaves errors that the other watched parameters (target offsets,
base, joint zeros) would explain significantly better: a nested F-test on the points
(only_changed_probability). That test does not depend on σ, so points measured through images
after the calibration, whose errors include more than the calibration's σ̂ (the stereo
calibration's error at new poses), are not refused for that.

The fewest poses (`propose_poses`): the check's own points were measured after the change, so
they count as data. New poses are added one at a time from feasible (visible) candidates, each the
one that most lowers the predicted mean squared error of the updated model over those candidates,
tr(W·P) with W the mean of Φ(q)ᵀΦ(q) over the candidates and P = (ΦᵀΦ/σ² + prior)⁻¹ the
posterior covariance (a Bayesian I-optimal design, the prior and the poses measured so far
included), until that predicted error is within `accuracy` × the calibration's own, tr(W·C)
(what a full calibration of the same kind achieves). The check's points count with their own
noise when it is larger than σ (`measured_scale`, from the check's residuals once the change is
fitted, core.monitoring.diagnosis.CandidateFit.noise_scale): the check poses sit at the
workspace's edges, where points measured through images err more than the calibration's σ̂, and
a re-identification resting on them alone puts those errors into the changed parameters. Those
errors are also systematic (the stereo calibration's, the same at a pose every time), which no
noise scale shows, so for check points measured with their own covariance (`new_per_parameter`:
the marker located in images, or a file's σ) at least one new pose per changed parameter is
proposed. Through rendered images, over 10 chained changes each re-identified against a full
recalibration: with that rule the held-out ratio was 0.91 for the tool, 1.14 for the base (6 new
poses); with one new pose at least, 0.96 and 1.35 (base:0.5 took 1 new pose and erred 0.0040 mm
against the full recalibration's 0.0029 mm). Points with independent errors (ideal measurements)
need no such floor: a tool swap was re-identified at 0.96 × a full recalibration with 1–2 new
poses, 0.93 with the 3 the rule would add.

The check's points located in images carry their own covariance, which the check's limits and
the diagnosis use; its factor (noise_scale) is then relative to that covariance. Here every point
counts with σ times that factor, not with its own σ: weighing each by its own σ (the new poses'
too) made the base's held-out ratio through images 1.36 (1.21 with the check points alone so
weighed) against 1.14, the tool's 1.05 against 0.91: four fifths of an image point's error
variance is the same at a pose every time it is imaged, which its own σ does not tell apart.

What bounds the result is the prior: a re-identification keeps the previous calibration's errors
in the parameters that did not change, and through images one calibration's held-out error
scatters by a factor 2–3 between pose draws (0.0027–0.0067 mm for 30 poses of the lab). Points
measured through images at 160 random poses erred 0.0075 mm RMS (3D, mostly along the cameras'
depth; about four fifths of its variance the same at a pose every time it is imaged). With that error
model the predicted ratio after N new random poses matched the measured one pooled over six
calibrations (tool, 8 poses: 1.03 predicted, 1.05 measured; 20 poses: 0.75 and 0.76; a joint
zero, 8 poses: 0.89 and 0.92; the base is the least well predicted, 1.16 and 1.37 at 8 poses,
1.00 and 1.09 at 12).
"""
from __future__ import annotations

import copy
import math
from dataclasses import dataclass
from datetime import datetime, timezone
from pathlib import Path
from typing import Sequence

import numpy as np
from scipy.stats import f as f_dist

from core.errors import RoboCalError
from core.kinematics.identifiability import characteristic_scales
from core.kinematics.jacobian import (Parameter, apply_step, calibration_jacobian, display_value,
                                      parameter_difference, predict_points)
from core.measurement.file import Measurements, check_against_robot
from core.monitoring.check_poses import watched_parameters
from core.monitoring.uncertainty import CalibrationUncertainty
from core.poses.candidates import generate_candidates, no_candidate_error
from core.poses.ordering import home_configuration, order_poses
from core.poses.selection import minimum_poses
from core.robot.file import write_robot
from core.robot.model import RobotModel
from core.task import Monitor

ITERATIONS = 10


DEFAULT_ACCURACY = 1.15    # predicted RMS error of the updated model / the calibration's own


@dataclass
class Proposal:
    """The proposed configurations in visiting order, Q (N, n; rad / mm) and q_file (file units),
    the predicted RMS error (mm, 3D, from the parameters' uncertainty) of the re-identified model
    over the visible workspace with the measured poses alone and after each proposed pose
    (N + 1 values, in the order they were chosen), and the calibration's own (reference_mm)."""

    Q: np.ndarray
    q_file: np.ndarray
    predicted_mm: np.ndarray
    reference_mm: float

    @property
    def predicted_ratio(self) -> float:
        """Predicted RMS error of the re-identified model / the calibration's own."""
        return float(self.predicted_mm[-1] / self.reference_mm)


def _prior_information(unc: CalibrationUncertainty, params: Sequence[Parameter], changed: set[str]) -> np.ndarray:
    """The prior's information matrix over `params`: the marginal of C over the unchanged ones, 0 on the changed."""
    index = {p.name: k for k, p in enumerate(unc.parameters)}
    u = [k for k, p in enumerate(params) if p.name not in changed]
    R = _prior_rows(unc.covariance[np.ix_([index[params[k].name] for k in u], [index[params[k].name] for k in u])])
    info = np.zeros((len(params), len(params)))
    info[np.ix_(u, u)] = R.T @ R
    return info


def propose_poses(model: RobotModel, unc: CalibrationUncertainty, changed: Sequence[Parameter],
                  measured=None, *, count: int | None = None, accuracy: float = DEFAULT_ACCURACY,
                  max_count: int | None = None, target: str = "marker", candidates: int = 600, seed: int = 0,
                  measured_scale: float = 1.0, new_per_parameter: bool = False, progress=None, cancelled=None,
                  **options) -> Proposal:
    """The fewest new poses that, with the configurations `measured` (M, n; rad / mm) after the
    change (the check's points), bring the predicted error of re-identifying `changed` with the
    calibration `unc` as prior within `accuracy` × the calibration's own (see the module); at most
    `max_count` (default 2·p_K), or exactly `count`. The `measured` points count with noise
    σ·`measured_scale` (≥ 1). `new_per_parameter`: propose at least one new pose per changed
    parameter (for `measured` points whose errors repeat at a pose, see the module). `options` go to
    core.poses.candidates.generate_candidates (rig, plate_size, visibility, floor, margin)."""
    monitor = Monitor(progress, cancelled)
    names = {p.name for p in changed}
    if not names:
        raise RoboCalError("nothing changed, so there is nothing to re-identify")
    measured = np.zeros((0, model.dof)) if measured is None else np.atleast_2d(np.asarray(measured, dtype=float))
    cands = generate_candidates(model, candidates, seed=seed, target=target, progress=monitor.sub(0.0, 0.6),
                                cancelled=cancelled, **options)
    if len(cands) == 0:
        raise no_candidate_error(cands, model, with_rig=options.get("rig") is not None)
    monitor.step(0.6, "information of the candidate poses")
    params = list(unc.parameters) + [p for p in changed if p.name not in set(unc.names)]
    scale = characteristic_scales(model, params)          # columns in 'mm at the tool'
    sigma = unc.sigma_mm
    A = (calibration_jacobian(model, cands.Q, [target] * len(cands), params) / scale / sigma
         ).reshape(len(cands), 3, len(params))
    W = sigma ** 2 * np.einsum("mij,mik->jk", A, A) / len(cands)      # mm² per unit scaled parameter²
    C = np.zeros((len(params), len(params)))
    C[:len(unc.parameters), :len(unc.parameters)] = unc.covariance
    reference = math.sqrt(float(np.trace(W @ (C * np.outer(scale, scale)))))
    info = _prior_information(unc, params, names) / np.outer(scale, scale)
    if len(measured):
        J0 = calibration_jacobian(model, measured, [target] * len(measured), params) / scale / sigma / \
            max(float(measured_scale), 1.0)
        info = info + J0.T @ J0
    info = info + 1e-9 * max(float(np.max(np.diag(info))), 1.0) * np.eye(len(params))  # changed set not yet determined
    P = np.linalg.inv(info)
    enough = minimum_poses(model, [target], fixed=[p.name for p in params if p.name not in names])
    limit = int(count) if count is not None else (2 * len(names) if max_count is None else int(max_count))
    fewest = len(names) if new_per_parameter else 0
    chosen: list[int] = []
    predicted = [math.sqrt(max(float(np.trace(W @ P)), 0.0))]
    while len(chosen) < limit:
        if count is None and len(chosen) >= min(fewest, limit) and len(measured) + len(chosen) >= enough \
                and predicted[-1] <= accuracy * reference:
            break
        monitor.step(0.6 + 0.35 * len(chosen) / max(limit, 1), f"choosing pose {len(chosen) + 1}")
        B = A @ P                                                   # (M, 3, L)
        S = np.eye(3) + B @ A.transpose(0, 2, 1)
        gain = np.trace(np.linalg.solve(S, B @ W @ B.transpose(0, 2, 1)), axis1=1, axis2=2)
        gain[chosen] = -np.inf
        k = int(np.argmax(gain))
        chosen.append(k)
        Bk = B[k]
        P = P - Bk.T @ np.linalg.solve(S[k], Bk)
        P = 0.5 * (P + P.T)
        predicted.append(math.sqrt(max(float(np.trace(W @ P)), 0.0)))
    Q = cands.Q[chosen]
    q_file = np.atleast_2d(model.q_to_file(Q)).reshape(len(Q), model.dof)
    order = order_poses(q_file, model.q_to_file(home_configuration(model))) if len(Q) > 1 else np.arange(len(Q))
    monitor.step(1.0, "poses proposed")
    return Proposal(Q[order], q_file[order], np.array(predicted), reference)


@dataclass
class Reidentification:
    """The updated model (its calibration section carries the new covariance and the history),
    the parameters re-estimated, and the errors on the data used before and after (mm)."""

    model: RobotModel
    previous: RobotModel
    changed: list[str]
    parameters: list[Parameter]
    covariance: np.ndarray
    rms_before_mm: float
    rms_after_mm: float
    n_poses: int
    reason: str

    def change(self) -> dict[str, float]:
        """New − previous value of each re-identified parameter (mm / deg; the base as the move of
        its origin and the small rotation about the measurement frame's axes)."""
        params = [p for p in self.parameters if p.name in self.changed]
        delta = parameter_difference(self.model, self.previous, params)
        return {p.name: float(d * p.to_display) for p, d in zip(params, delta)}

    def summary(self) -> dict:
        return {"changed": self.changed, "change": self.change(), "rms_before_mm": self.rms_before_mm,
                "rms_after_mm": self.rms_after_mm, "n_poses": self.n_poses, "reason": self.reason}


def _prior_rows(C: np.ndarray) -> np.ndarray:
    """R with RᵀR = C⁻¹ (column-scaled eigen-decomposition; directions C leaves at 0 are dropped)."""
    if C.size == 0:
        return np.zeros((0, 0))
    D = np.sqrt(np.clip(np.diag(C), 1e-300, None))
    lam, V = np.linalg.eigh(C / np.outer(D, D))
    keep = lam > 1e-12 * lam.max()
    return (V[:, keep] / np.sqrt(lam[keep])).T / D


def reidentify(model: RobotModel, unc: CalibrationUncertainty, changed: Sequence[Parameter],
               meas: Measurements, *, noise_scale=None, reason: str = "", previous: str = "",
               alpha: float = 0.01, progress=None, cancelled=None) -> Reidentification:
    """Re-estimate `changed` from `meas` (new poses, check points) with the previous calibration
    as the prior (see the module). `noise_scale`: per point of `meas`, its noise as a multiple
    (≥ 1) of the calibration's σ (None: all 1), e.g. the check's points' `measured_scale` of
    `propose_poses`, so that they weigh in the fit as they did in the proposal. Raises
    RoboCalError when the new fit does not explain the measurements (then nothing is to be
    written)."""
    monitor = Monitor(progress, cancelled)
    changed_names = [p.name for p in changed]
    if not changed_names:
        raise RoboCalError("nothing changed, so there is nothing to re-identify")
    meas = meas.with_robot(model) if meas.Q is None or meas.Q.shape[1] != model.dof else meas
    check_against_robot(meas, model)
    params = list(unc.parameters) + [p for p in changed if p.name not in set(unc.names)]
    u_idx = [k for k, p in enumerate(unc.parameters) if p.name not in set(changed_names)]
    R = _prior_rows(unc.covariance[np.ix_(u_idx, u_idx)])
    sigma = unc.sigma_mm * _point_scales(noise_scale, meas.n_points)[:, None]      # (N, 1) mm
    m = 3 * meas.n_points
    total = np.zeros(len(params))
    current = model

    def stacked(mdl, tot):
        r = ((meas.xyz - predict_points(mdl, meas.Q, meas.target)) / sigma).reshape(-1)
        J = calibration_jacobian(mdl, meas.Q, meas.target, params) / np.repeat(sigma, 3, axis=0)
        Jp = np.zeros((R.shape[0], len(params)))
        Jp[:, u_idx] = R
        return np.concatenate([r, -R @ tot[u_idx]]), np.vstack([J, Jp])

    before = float(np.sqrt(np.mean(np.sum((meas.xyz - predict_points(model, meas.Q, meas.target)) ** 2, axis=1))))
    for it in range(ITERATIONS):
        monitor.step(it / ITERATIONS, f"re-identifying: iteration {it + 1}")
        b, A = stacked(current, total)
        scale = np.linalg.norm(A, axis=0)
        scale = np.where(scale > 0, scale, 1.0)
        x = np.linalg.lstsq(A / scale, b, rcond=1e-10)[0] / scale
        current = apply_step(current, params, x)
        total = total + x
        if float(np.linalg.norm(x * scale)) < 1e-9 * (1.0 + float(np.linalg.norm(b))):
            break
    b, A = stacked(current, total)
    after = float(np.sqrt(np.mean(np.sum((meas.xyz - predict_points(current, meas.Q, meas.target)) ** 2, axis=1))))
    _require_determined(current, meas, [p for p in params if p.name in set(changed_names)], changed_names)
    probability = only_changed_probability(current, meas, params, changed_names, b[:m],
                                           point_scales=sigma[:, 0] / unc.sigma_mm)
    if probability < alpha:
        raise RoboCalError(
            f"re-identifying {', '.join(changed_names)} leaves errors of {after:.3f} mm RMS on the "
            f"{meas.n_poses} poses that the robot's other parameters (base, tool, joint zeros) would explain "
            f"much better (probability {probability:.1e} that only these changed)",
            hint="The change is not only in these parameters: run a full calibration.")
    scale = np.linalg.norm(A, axis=0)
    scale = np.where(scale > 0, scale, 1.0)
    cov = np.linalg.pinv((A / scale).T @ (A / scale)) / np.outer(scale, scale)
    cov = 0.5 * (cov + cov.T)
    out = current.copy()
    out.calibration = _updated_calibration(model.calibration, current, params, cov, changed_names, reason,
                                           previous, meas.n_poses, before, after)
    monitor.step(1.0, "re-identified")
    return Reidentification(out, model, changed_names, params, cov, before, after, meas.n_poses, reason)


def _point_scales(noise_scale, n: int) -> np.ndarray:
    """Per point σ multipliers (n,), each at least 1; all 1 for None."""
    if noise_scale is None:
        return np.ones(n)
    scale = np.broadcast_to(np.asarray(noise_scale, dtype=float), (n,))
    return np.maximum(scale, 1.0)


def _updated_calibration(old: dict | None, model: RobotModel, params: Sequence[Parameter], cov: np.ndarray,
                         changed: list[str], reason: str, previous: str, n_poses: int, before: float,
                         after: float) -> dict:
    cal = copy.deepcopy(old) if isinstance(old, dict) else {"format": "robocal.calibration/1"}
    std = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    index = {p.name: k for k, p in enumerate(params)}
    for row in cal.get("parameters", []) or []:
        if isinstance(row, dict) and row.get("name") in index:
            k = index[row["name"]]
            row["identified"] = display_value(model, params[k])
            row["std"] = float(std[k] * params[k].to_display)
    cal["covariance"] = {"parameters": [p.name for p in params], "units": "mm and rad",
                         "matrix": [[float(v) for v in r] for r in cov]}
    history = list(cal.get("history", []) or [])
    history.append({"date": datetime.now(timezone.utc).replace(microsecond=0).isoformat(),
                    "updated": Path(previous).name if previous else "", "reason": reason,
                    "changed": list(changed), "poses": int(n_poses),
                    "rms_before_mm": before, "rms_after_mm": after})
    cal["history"] = history
    return cal


def write_reidentified(result: Reidentification, path: str | Path) -> Path:
    """Write the updated calibrated robot file atomically (a failure leaves any file there intact)."""
    return write_robot(result.model, path)


def _require_determined(model: RobotModel, meas: Measurements, changed: Sequence[Parameter], names: list[str]) -> None:
    """RoboCalError when the measured poses alone cannot determine every changed parameter (the
    Jacobian of the changed set on these poses is rank deficient)."""
    J = calibration_jacobian(model, meas.Q, meas.target, list(changed))
    scale = np.linalg.norm(J, axis=0)
    rank = int(np.linalg.matrix_rank(J / np.where(scale > 0, scale, 1.0), tol=1e-8)) if J.size else 0
    if rank < len(changed):
        raise RoboCalError(f"the {meas.n_poses} measured poses determine only {rank} of the {len(changed)} "
                           f"changed parameters ({', '.join(names)})",
                           hint="Measure the proposed poses (all of them) together with the check's points, "
                                "or run a full calibration.")


def only_changed_probability(model: RobotModel, meas: Measurements, params: Sequence[Parameter],
                             changed: Sequence[str], residual, *, point_scales=None) -> float:
    """The nested F-test's p-value that the re-identified set K explains the points as well as K
    together with every watched parameter (target offsets, base, joint zeros): with the residual
    r after the fit of K and the best linear fit of all of them F (RSS_K, RSS_F, ranks p_K, p_F),
    F = ((RSS_K − RSS_F)/(p_F − p_K)) / (RSS_F/(3N − p_F)) against F(p_F − p_K, 3N − p_F). The
    ratio does not depend on the points' noise, which for points measured through images after
    the calibration is larger than the calibration's own σ (its stereo part is not in it). 1.0
    when the points leave no degrees of freedom for the test. `residual` is weighted by each point's
    σ multiplier `point_scales` (N,; None: all equal), and so are the Jacobian's rows here."""
    r = np.asarray(residual, dtype=float)
    rows = np.repeat(_point_scales(point_scales, meas.n_points), 3)[:, None]
    keep = set(changed)
    watched = {p.name for p in watched_parameters(model, list(dict.fromkeys(meas.target)))}
    full = [p for p in params if p.name in keep or p.name in watched]
    K = [p for p in params if p.name in keep]

    def fit(ps):
        J = calibration_jacobian(model, meas.Q, meas.target, ps) / rows
        scale = np.linalg.norm(J, axis=0)
        Js = J / np.where(scale > 0, scale, 1.0)
        x, _, rank, _ = np.linalg.lstsq(Js, r, rcond=1e-8)
        e = r - Js @ x
        return float(e @ e), int(rank)

    rss_f, p_f = fit(full)
    _, p_k = fit(K)
    rss_k = float(r @ r)
    dof = len(r) - p_f
    if p_f <= p_k or dof < p_f - p_k:           # too few points to tell the alternatives apart
        return 1.0
    stat = ((rss_k - rss_f) / (p_f - p_k)) / max(rss_f / dof, 1e-300)
    return float(f_dist.sf(max(stat, 0.0), p_f - p_k, dof))
