"""Re-identification of what changed, from a few poses, with the previous calibration as a prior.

The parameters of the previous calibration keep their estimate and covariance C as a Gaussian
prior, except the changed set K, which is free (the limit of an infinite prior variance on K:
the prior on the others is the marginal of C over them). Gauss–Newton minimises

    Σ |x_measured − x_model|² / σ²  +  δ_Uᵀ·C_UU⁻¹·δ_U

over the corrections δ of all those parameters (δ_U those of the unchanged ones), so that
the new poses mostly move K and the unchanged parameters only as far as the data ask. The
posterior covariance (ΦᵀΦ/σ² + prior)⁻¹ is written into the new calibrated file, so the next
checks take their limits from it.

The fewest poses: core.poses.selection.select_poses for K alone (every other parameter fixed)
proposes max(its minimum + 1, ⌈2·p_K/3⌉) poses chosen by observability of K.
"""
from __future__ import annotations

import copy
import math
from dataclasses import dataclass
from datetime import datetime, timezone
from pathlib import Path
from typing import Sequence

import numpy as np
from scipy.stats import chi2

from core.errors import RoboCalError
from core.identification.jacobian import (Parameter, all_parameters, apply_step, calibration_jacobian,
                                          parameter_difference, predict_points)
from core.identification.solver import display_value
from core.measurement.file import Measurements, check_against_robot
from core.monitoring.uncertainty import CalibrationUncertainty
from core.poses.selection import PoseSelectionResult, minimum_poses, select_poses
from core.robot.file import write_robot
from core.robot.model import RobotModel
from core.task import Monitor

ITERATIONS = 10


def poses_for(model: RobotModel, changed: Sequence[Parameter], target: str = "marker") -> int:
    """How many new poses to propose for re-identifying `changed`."""
    names = {p.name for p in changed}
    fixed = [p.name for p in all_parameters(model, [target]) if p.name not in names]
    return max(minimum_poses(model, [target], fixed=fixed) + 1, math.ceil(2 * len(names) / 3))


def propose_poses(model: RobotModel, changed: Sequence[Parameter], *, count: int | None = None,
                  target: str = "marker", progress=None, cancelled=None, **options) -> PoseSelectionResult:
    """The few poses that best determine the `changed` parameters (others fixed); `options` go
    to core.poses.selection.select_poses (rig, plate_size, visibility, floor, candidates …)."""
    names = {p.name for p in changed}
    if not names:
        raise RoboCalError("nothing changed, so there is nothing to re-identify")
    fixed = [p.name for p in all_parameters(model, [target]) if p.name not in names]
    count = poses_for(model, changed, target) if count is None else int(count)
    options.setdefault("random_trials", 20)
    options.setdefault("curve_max", count)
    return select_poses(model, count, target=target, targets=[target], fixed=fixed, progress=progress,
                        cancelled=cancelled, **options)


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
               meas: Measurements, *, reason: str = "", previous: str = "", alpha: float = 0.01,
               progress=None, cancelled=None) -> Reidentification:
    """Re-estimate `changed` from `meas` (new poses, check points) with the previous calibration
    as the prior (see the module). Raises RoboCalError when the new fit does not explain the
    measurements (then nothing is to be written)."""
    monitor = Monitor(progress, cancelled)
    changed_names = [p.name for p in changed]
    if not changed_names:
        raise RoboCalError("nothing changed, so there is nothing to re-identify")
    meas = meas.with_robot(model) if meas.Q is None or meas.Q.shape[1] != model.dof else meas
    check_against_robot(meas, model)
    params = list(unc.parameters) + [p for p in changed if p.name not in set(unc.names)]
    u_idx = [k for k, p in enumerate(unc.parameters) if p.name not in set(changed_names)]
    R = _prior_rows(unc.covariance[np.ix_(u_idx, u_idx)])
    sigma = unc.sigma_mm
    m = 3 * meas.n_points
    total = np.zeros(len(params))
    current = model

    def stacked(mdl, tot):
        r = ((meas.xyz - predict_points(mdl, meas.Q, meas.target)) / sigma).reshape(-1)
        J = calibration_jacobian(mdl, meas.Q, meas.target, params) / sigma
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
    rss = float(b[:m] @ b[:m])
    dof = m - len(changed_names)
    after = float(np.sqrt(np.mean(np.sum((meas.xyz - predict_points(current, meas.Q, meas.target)) ** 2, axis=1))))
    if dof > 0 and chi2.sf(rss, dof) < alpha:
        raise RoboCalError(
            f"re-identifying {', '.join(changed_names)} leaves errors of {after:.3f} mm RMS on the "
            f"{meas.n_poses} poses, more than the calibration's noise of {sigma:.3f} mm allows",
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
