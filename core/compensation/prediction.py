"""The error a calibrated model predicts for a tool point it is sent to: the identified
parameters' covariance C (core.monitoring.uncertainty) propagated to the point,
S_i = Φ_i·C·Φ_iᵀ (3x3, mm², measurement frame), Φ_i the calibration Jacobian at the point's
joints (core.kinematics.jacobian). Only the model's part: the cameras' noise is not in it.

Per point: σ = √trace(S_i) (the RMS length of the error, mm) and the length the error stays below
with `probability`: the quantile of a weighted χ² (as core.monitoring.uncertainty.norm_limit,
which is exact but slow) read from a table over the ratios of S_i's eigenvalues (`_limits`), so
that thousands of points take milliseconds.
"""
from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np

from core.compensation.ik import TOOL_TCP, tcp_in_tool
from core.kinematics.jacobian import calibration_jacobian
from core.monitoring.uncertainty import CalibrationUncertainty, calibration_uncertainty
from core.robot.model import RobotModel

GRID = np.linspace(0.0, 1.0, 21)
SAMPLES = 2 ** 17
_POINT = "__tcp__"      # the tool point as a target of a model copy (no parameters of its own)


@dataclass
class PredictedError:
    """Per point (N,): `sigma_mm` the RMS length of the predicted position error, `limit_mm` the
    length it stays below with `probability`; `covariance` (N, 3, 3) mm² in the measurement frame."""

    sigma_mm: np.ndarray
    limit_mm: np.ndarray
    probability: float
    covariance: np.ndarray


def point_covariances(model: RobotModel, unc: CalibrationUncertainty, Q, tcp: str) -> np.ndarray:
    """S_i (N, 3, 3) mm² of the tool point `tcp` at Q (N, n), from the parameters' covariance."""
    Q = np.atleast_2d(np.asarray(Q, dtype=float))
    T = tcp_in_tool(model, tcp)
    work = model.copy()
    if tcp == TOOL_TCP or tcp not in [p.target for p in unc.parameters]:
        work.targets = dict(work.targets)
        work.targets[_POINT] = T[:3, 3].copy()
        name = _POINT
    else:
        name = tcp
    if len(Q) == 0:
        return np.zeros((0, 3, 3))
    J = calibration_jacobian(work, Q, [name] * len(Q), unc.parameters).reshape(len(Q), 3, -1)
    return np.einsum("nip,pq,njq->nij", J, unc.covariance, J)


@functools.lru_cache(maxsize=4)
def _shape_table(probability: float) -> np.ndarray:
    """The `probability` quantile of √(z1² + u·z2² + u·v·z3²)/√(1 + u + u·v) on the grid
    (u, v) ∈ GRID² (z standard normal), from SAMPLES fixed quasi-random draws (Sobol, scrambled,
    seed 0): relative error about 0.1 % (tests compare with norm_limit)."""
    from scipy.stats import norm, qmc
    z2 = norm.ppf(qmc.Sobol(3, scramble=True, seed=0).random(SAMPLES)) ** 2
    table = np.empty((len(GRID), len(GRID)))
    for i, u in enumerate(GRID):
        for j, v in enumerate(GRID):
            lam = np.array([1.0, u, u * v])
            table[i, j] = np.sqrt(np.quantile(z2 @ lam, probability) / lam.sum())
    return table


def _limits(S: np.ndarray, probability: float) -> np.ndarray:
    """The length each 3x3 covariance's error stays below with `probability`: the table of
    `_shape_table` at the ratios of its eigenvalues (λ2/λ1, λ3/λ2), interpolated, times √Σλ."""
    from scipy.interpolate import RegularGridInterpolator

    lam = np.clip(np.linalg.eigvalsh(S), 0.0, None)[:, ::-1]       # descending
    total = lam.sum(axis=1)
    out = np.zeros(len(S))
    pos = total > 0
    l = lam[pos]
    u = np.divide(l[:, 1], l[:, 0], out=np.zeros(len(l)), where=l[:, 0] > 0)
    v = np.divide(l[:, 2], l[:, 1], out=np.zeros(len(l)), where=l[:, 1] > 0)
    f = RegularGridInterpolator((GRID, GRID), _shape_table(float(probability)), method="cubic")
    out[pos] = f(np.column_stack([u, v])) * np.sqrt(total[pos])
    return out


def predicted_error(model: RobotModel, Q, tcp: str = "marker", *, uncertainty: CalibrationUncertainty | None = None,
                    probability: float = 0.95) -> PredictedError:
    """The predicted position error of the tool point `tcp` at the joints Q (N, n) of a
    calibrated `model` (its calibration section, or `uncertainty`). RoboCalError for a robot
    file without a calibration covariance."""
    unc = uncertainty if uncertainty is not None else calibration_uncertainty(model)
    S = point_covariances(model, unc, Q, tcp)
    sigma = np.sqrt(np.clip(np.trace(S, axis1=1, axis2=2), 0.0, None))
    return PredictedError(sigma, _limits(S, probability) if len(S) else np.zeros(0), probability, S)
