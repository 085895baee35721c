"""The Levenberg–Marquardt loop of identification: corrections of the free parameters that
minimise the weighted squared point errors (mm²), with the orientation rows and the prior's
penalty rows when given. Our own short loop rather than scipy.optimize.least_squares: it records
every iteration's cost for the GUI, checks Cancel between iterations (through the Monitor), and
updates the base rotation through the exponential map at each step so the analytic Jacobian
stays exact. With damping λ = 0 a step is exactly the chapter's eq. (9–10)."""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np

from core.errors import RoboCalError
from core.identification.orientation import orientation_residuals
from core.identification.prior import PriorTerm
from core.identification.result import IterationRecord
from core.kinematics.identifiability import column_scales, qr_r
from core.kinematics.jacobian import Parameter, apply_step, calibration_jacobian, predict_points
from core.kinematics.orientation import orientation_jacobian
from core.measurement.file import Measurements
from core.robot.model import RobotModel
from core.task import Monitor


@dataclass
class LMOutcome:
    model: RobotModel
    converged: bool
    iterations: int


def levenberg_marquardt(model: RobotModel, meas: Measurements, free: Sequence[Parameter],
                        weights: np.ndarray, *, monitor: Monitor | None = None,
                        records: list[IterationRecord] | None = None, stage: str = "fit",
                        damping: float = 1e-3, max_iterations: int = 100, ftol: float = 1e-10,
                        xtol: float = 1e-10, prior: PriorTerm | None = None,
                        orientation_weights: np.ndarray | None = None) -> LMOutcome:
    """Minimise Σ w·|x_measured − x_model|² over the corrections of `free`, starting at `model`.

    Each step solves (AᵀA + λI)·x = Aᵀb with A = √W·Φ·D⁻¹ (columns scaled by their norms D,
    kept as the running maximum as in MINPACK), b = √W·Δx, and the correction is Δg = D⁻¹·x;
    λ = 0 is the Gauss–Newton step of eq. (9–10). λ adapts as in Nielsen's rule. Stops when
    the relative cost decrease is below `ftol` or the scaled step below `xtol`·|b|.
    `weights` are per coordinate (N, 3). With a `prior`, its penalty rows are appended to Φ and
    Δx (core.identification.prior) and the cost includes the penalty. With `orientation_weights`
    (N, 3, rad⁻²), the measured orientations' rows follow the points' (core.identification.orientation)."""
    monitor = monitor or Monitor()
    records = records if records is not None else []
    sw = np.sqrt(np.asarray(weights, dtype=float).reshape(-1))
    meas_xyz = meas.xyz.reshape(-1)

    sw_o = None if orientation_weights is None else np.sqrt(np.asarray(orientation_weights, float).reshape(-1))

    def residual(m):
        b = sw * (meas_xyz - predict_points(m, meas.Q, meas.target).reshape(-1))
        if sw_o is not None:
            b = np.concatenate([b, sw_o * orientation_residuals(m, meas).reshape(-1)])
        return b if prior is None else np.concatenate([b, prior.rows(m, free)[1]])

    def jacobian(m):
        J = sw[:, None] * calibration_jacobian(m, meas.Q, meas.target, free)
        if sw_o is not None:
            J = np.vstack([J, sw_o[:, None] * orientation_jacobian(m, meas.Q, meas.target, free)])
        return J if prior is None else np.vstack([J, prior.rows(m, free)[0]])

    b = residual(model)
    cost = float(b @ b)
    rms = lambda m: float(np.sqrt(np.mean(np.sum((meas.xyz - predict_points(m, meas.Q, meas.target)) ** 2, axis=1))))
    records.append(IterationRecord(0 if not records else records[-1].iteration, cost, rms(model), 0.0, 0.0,
                                   stage, start=True))
    if not free:
        return LMOutcome(model, True, 0)
    J = jacobian(model)
    D = column_scales(J)
    lam, nu = float(damping), 2.0
    converged, done = False, 0
    floor = 1e-18 * len(b)          # (1e-9 mm)² per coordinate: exact to round-off
    for _ in range(max_iterations * 4):
        if done >= max_iterations:
            break
        monitor.step(min(done / max(max_iterations, 1), 1.0), f"iteration {done + 1}: RMS {records[-1].rms_mm:.4f} mm")
        A = np.where(np.isfinite(D), J / D, 0.0)
        x = _damped_solve(A, b, lam)
        step = np.where(np.isfinite(D), x / D, 0.0)
        predicted = float(b @ b - np.sum((b - A @ x) ** 2))
        trial = apply_step(model, free, step)
        b_t = residual(trial)
        cost_t = float(b_t @ b_t)
        if not math.isfinite(cost_t):
            raise RoboCalError("the estimation diverged (the model's predictions became invalid)",
                               hint="Check that the robot model and the measurements belong together.")
        if cost_t < cost:
            rho = (cost - cost_t) / predicted if predicted > 0 else 0.0
            small_change = (cost - cost_t) <= ftol * cost
            small_step = float(np.linalg.norm(x)) <= xtol * (math.sqrt(cost) + xtol)
            model, b, cost = trial, b_t, cost_t
            done += 1
            records.append(IterationRecord(records[-1].iteration + 1, cost, rms(model), lam,
                                           float(np.linalg.norm(x)), stage))
            lam = lam * max(1.0 / 3.0, 1.0 - (2.0 * rho - 1.0) ** 3) if lam > 0 else 0.0
            nu = 2.0
            if small_change or small_step or cost <= floor:
                converged = True
                break
            J = jacobian(model)
            Dn = column_scales(J)
            D = np.where(np.isfinite(D), np.fmax(D, Dn), Dn)
        else:
            # no decrease: at the minimum the linear model predicts no gain either
            if predicted <= ftol * cost or cost <= floor:
                converged = True
                break
            lam = max(lam, 1e-6) * nu
            nu *= 2.0
            if lam > 1e12:
                break
    return LMOutcome(model, converged, done)


def _damped_solve(A: np.ndarray, b: np.ndarray, lam: float) -> np.ndarray:
    """argmin |A·x − b|² + λ|x|² through A = Q·R and the SVD of the small R (minimum norm when
    λ = 0 and A is rank deficient)."""
    R, c = qr_r(A, b)
    U, s, Vt = np.linalg.svd(R)
    if lam > 0:
        f = s / (s ** 2 + lam)
    else:
        f = np.where(s > 1e-12 * max(s[0], 1e-300), 1.0 / np.where(s > 0, s, 1.0), 0.0)
    return Vt.T @ (f * (U.T @ c))
