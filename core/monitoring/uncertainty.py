"""What a calibration predicts about its own errors: the covariance of the identified
parameters (from the calibrated robot file) propagated to a point, plus the measurement noise.

For check points at configurations Q (N, n) the predicted difference e = measured − model has
covariance  S = Φ·C·Φᵀ + M  (3N × 3N, mm²), with Φ the calibration Jacobian of the
estimated parameters (core.kinematics.jacobian), C their covariance and M the measurement
noise, block-diagonal: σ²·I per point (σ per axis, mm), or for a point measured with its own
covariance Σ_i (the marker locator's, core.measurement.point) that covariance scaled by
s_i = max(k², σ² / (tr Σ_i / 3)): k the calibration's noise factor (for a calibration that weighted
its points by their own σ, its unitless σ̂; 1 otherwise), σ a floor on its mean variance per axis
(no point measured after the calibration is taken, on average over its axes, as better predicted
than the calibration's own errors, its held-out ones included).
So a point the cameras see from afar or at a slant, which they measure less precisely, gets the
wider limit its own covariance gives; through images the locator's 3D σ at the check poses of the
virtual lab spans 0.0045–0.011 mm, 1.0–2.4 × the calibration's σ·√3. The parameter part
correlates the points (they share the same model).

Limits on error lengths: |e|² = Σ λ_i·z_i² with λ the eigenvalues of S is a weighted sum of
χ²₁ variables; its tail probability is computed by Imhof's (1961) integral and the quantile
found by root finding, starting from the Satterthwaite–Welch approximation |e|² ≈ c·χ²_ν
(c = Σλ²/Σλ, ν = (Σλ)²/Σλ²), which is exact for an isotropic S.
"""
from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Sequence

import numpy as np
from scipy.integrate import quad
from scipy.optimize import brentq
from scipy.stats import chi2

from core.errors import RoboCalError
from core.kinematics.jacobian import Parameter, all_parameters, calibration_jacobian
from core.robot.model import RobotModel


@dataclass
class CalibrationUncertainty:
    """The identified parameters' covariance (internal units: mm and rad; base rotations as small
    angles about the measurement frame's axes) and the measurement noise σ (mm per axis)."""

    parameters: list[Parameter]
    covariance: np.ndarray
    sigma_mm: float
    source: str = ""
    dof: float = math.inf          # degrees of freedom of σ (the calibration's m − p; inf if given)
    noise_factor: float = 1.0      # k: a weighted calibration's σ̂ (its errors / the points' own σ); 1 otherwise

    @property
    def names(self) -> list[str]:
        return [p.name for p in self.parameters]

    def measurement_covariance(self, own=None) -> np.ndarray:
        """The noise (3, 3) mm² of a point measured after the calibration, measurement frame: σ²·I,
        or for a point with its own covariance `own` that covariance scaled by
        max(k², σ² / (tr own / 3)) (see the module)."""
        floor = self.sigma_mm ** 2
        if own is None:
            return floor * np.eye(3)
        own = np.asarray(own, dtype=float).reshape(3, 3)
        mean = float(np.trace(own)) / 3.0
        if not math.isfinite(mean) or mean <= 0.0:
            return floor * np.eye(3)
        return max(self.noise_factor ** 2, floor / mean) * own


MAX_SIGMA_MM = 1000.0          # a larger measurement noise is no calibration (and overflows the limits)
MAX_VARIANCE = 1e12             # mm² / rad² of any identified parameter, for the same reason


def statistics_sigma_mm(stats: dict, source=None) -> float:
    """The measurement noise per axis (mm) of a calibration's `statistics`: its σ̂ when it is in mm;
    for a calibration that weighted its points by their own σ (σ̂ is then a unitless factor, its
    `sigma_hat_unit` not "mm"), the RMS 3D error after calibration per axis corrected for the
    parameters the fit absorbed, rms_after_mm / √3 · √(3N / dof); in both cases at least the
    error at the poses the calibration held out (held_out_sigma_mm). RoboCalError naming the
    field when neither σ̂ nor the RMS error is there."""
    if stats.get("sigma_hat_unit", "mm") == "mm":
        sigma = stats.get("sigma_hat")
        field = "calibration.statistics.sigma_hat"
    else:
        sigma = stats.get("rms_after_mm")
        field = "calibration.statistics.rms_after_mm"
    if not isinstance(sigma, (int, float)) or isinstance(sigma, bool) or not math.isfinite(sigma) or sigma <= 0:
        raise RoboCalError("expected a positive number (mm)", source=source, field=field,
                           hint="Use the calibrated robot file written by the Identification step (robocal identify).")
    if stats.get("sigma_hat_unit", "mm") == "mm":
        own = float(sigma)
    else:
        n, dof = stats.get("n_points"), stats.get("dof")
        absorbed = math.sqrt(3.0 * n / dof) if isinstance(n, int) and isinstance(dof, int) and 0 < dof <= 3 * n else 1.0
        own = float(sigma) / math.sqrt(3.0) * absorbed
    return max(own, held_out_sigma_mm(stats))


def statistics_noise_factor(stats: dict) -> float:
    """k of a calibration's `statistics`: its σ̂ when it weighted its points by their own σ (σ̂ is
    then unitless, `sigma_hat_unit` "1"), else 1 (and 1 when that σ̂ is not a positive number: a
    point's own covariance is then taken as it is)."""
    if stats.get("sigma_hat_unit", "mm") == "mm":
        return 1.0
    k = stats.get("sigma_hat")
    if not isinstance(k, (int, float)) or isinstance(k, bool) or not math.isfinite(k) or k <= 0:
        return 1.0
    return float(k)


def held_out_sigma_mm(stats: dict) -> float:
    """The calibration's error at the poses it held out (validation.after.rms_mm, 3D) per axis, mm;
    0 without a validation. A point measured after the calibration at other poses is predicted
    about that well: the error includes what the model cannot absorb (e.g. the stereo
    calibration's error away from the calibration's poses), which σ̂ of the fitted points does not."""
    after = ((stats.get("validation") or {}).get("after") or {}) if isinstance(stats.get("validation"), dict) else {}
    rms = after.get("rms_mm") if isinstance(after, dict) else None
    if not isinstance(rms, (int, float)) or isinstance(rms, bool) or not math.isfinite(rms) or rms <= 0:
        return 0.0
    return float(rms) / math.sqrt(3.0)


def _field(cal: dict, key: str, source, field: str):
    if key not in cal:
        raise RoboCalError("missing", source=source, field=field,
                           hint="Use the calibrated robot file written by the Identification step "
                                "(robocal identify) of this version.")
    return cal[key]


def calibration_uncertainty(model: RobotModel, *, source: str | Path | None = None,
                            sigma_mm: float | None = None) -> CalibrationUncertainty:
    """The uncertainty a calibrated robot file records (its `calibration.covariance` and
    `calibration.statistics`, see statistics_sigma_mm: its σ̂ in mm, or for a calibration that
    weighted its points the noise its own errors show). `sigma_mm` overrides the measurement noise.
    Raises RoboCalError naming the file and field for a file without them."""
    source = str(source) if source is not None else None
    cal = model.calibration
    if not isinstance(cal, dict):
        raise RoboCalError("this robot file holds no calibration", source=source, field="calibration",
                           hint="Give the calibrated robot file written by the Identification step.")
    cov = _field(cal, "covariance", source, "calibration.covariance")
    if not isinstance(cov, dict):
        raise RoboCalError("expected an object with 'parameters' and 'matrix'", source=source,
                           field="calibration.covariance")
    names = _field(cov, "parameters", source, "calibration.covariance.parameters")
    matrix = _field(cov, "matrix", source, "calibration.covariance.matrix")
    if not isinstance(names, list) or not all(isinstance(n, str) for n in names):
        raise RoboCalError("expected a list of parameter names", source=source,
                           field="calibration.covariance.parameters")
    # the deflection terms (core.robot.compliance) of a model that has them are parameters too
    known = {p.name: p for p in all_parameters(model, list(model.targets), compliance=True)}
    unknown = [n for n in names if n not in known]
    if unknown:
        raise RoboCalError(f"unknown parameter '{unknown[0]}' for this robot", source=source,
                           field="calibration.covariance.parameters",
                           hint="The calibration belongs to another robot model; identify this one again.")
    try:
        C = np.array(matrix, dtype=float)
    except (TypeError, ValueError):
        C = np.zeros((0, 0))
    p = len(names)
    if C.shape != (p, p) or not np.all(np.isfinite(C)) or not np.allclose(C, C.T, rtol=1e-6, atol=1e-18) \
            or np.any(np.diag(C) < 0):
        raise RoboCalError(f"expected a symmetric {p} × {p} matrix of numbers with a non-negative diagonal",
                           source=source, field="calibration.covariance.matrix")
    dof, factor = math.inf, 1.0
    stats = cal.get("statistics")
    if isinstance(stats, dict):
        factor = statistics_noise_factor(stats)
    if sigma_mm is None:
        stats = _field(cal, "statistics", source, "calibration.statistics")
        if not isinstance(stats, dict):
            raise RoboCalError("expected an object", source=source, field="calibration.statistics")
        sigma_mm = statistics_sigma_mm(stats, source)
        given = stats.get("dof")
        if isinstance(given, int) and not isinstance(given, bool) and given > 0:
            dof = float(given)
    if not 0.0 < sigma_mm <= MAX_SIGMA_MM:
        raise RoboCalError(f"the measurement noise must be between 0 and {MAX_SIGMA_MM:g} mm, got {sigma_mm:g} mm",
                           source=source, field="calibration.statistics.sigma_hat",
                           hint="The calibration did not converge to a usable result: calibrate again.")
    if float(np.max(np.abs(C), initial=0.0)) > MAX_VARIANCE:
        raise RoboCalError(f"a parameter variance beyond {MAX_VARIANCE:g} (mm² or rad²): the calibration did not "
                           "determine its parameters", source=source, field="calibration.covariance.matrix",
                           hint="Calibrate again with more poses (robocal select-poses).")
    return CalibrationUncertainty([known[n] for n in names], 0.5 * (C + C.T), float(sigma_mm),
                                  source or "", dof, factor)


def parameter_covariance(model: RobotModel, unc: CalibrationUncertainty, Q,
                         point_targets: Sequence[str]) -> np.ndarray:
    """Φ·C·Φᵀ (3N, 3N) in mm²: the calibration's parameter covariance propagated to the points at
    Q (N, n) with their target names."""
    Q = np.atleast_2d(np.asarray(Q, dtype=float))
    J = calibration_jacobian(model, Q, list(point_targets), unc.parameters)
    return J @ unc.covariance @ J.T


def with_measurement_noise(shared: np.ndarray, unc: CalibrationUncertainty, own=None) -> np.ndarray:
    """S: the parameter part `shared` (3N, 3N) mm² plus each point's measurement noise
    (CalibrationUncertainty.measurement_covariance of its own covariance, `own`: N of (3, 3) or
    None; None: no point has one)."""
    S = np.array(shared, dtype=float)
    n = len(S) // 3
    own = [None] * n if own is None else list(own)
    for i in range(n):
        S[3 * i:3 * i + 3, 3 * i:3 * i + 3] += unc.measurement_covariance(own[i])
    return S


def prediction_covariance(model: RobotModel, unc: CalibrationUncertainty, Q,
                          point_targets: Sequence[str], own=None) -> np.ndarray:
    """S (3N, 3N) in mm² of measured − predicted for points at Q (N, n) with their target names:
    the calibration's parameter covariance propagated through Φ, plus each point's measurement
    noise (σ² per coordinate, or its own covariance `own[i]` scaled, see the module)."""
    return with_measurement_noise(parameter_covariance(model, unc, Q, point_targets), unc, own)


def weighted_chi2_sf(x: float, lam: np.ndarray, memo: dict | None = None) -> float:
    """P(Σ λ_i·z_i² > x) for independent standard normal z_i (Imhof's integral; the
    oscillating tail beyond u = 1 with quad's Fourier-integral rule, QAWF).

    `memo` (u -> the integrand's angle and modulus at u, which do not depend on x) may be shared
    by calls for the same λ: the two parts of the tail evaluate them at the same u, and so do
    calls for several x on [0, 1]."""
    lam = [float(v) for v in np.ravel(lam)]     # plain floats: quad calls these ~10⁴ times a value
    w = 0.5 * x
    memo = {} if memo is None else memo

    def angle_rho(u):
        """(½ Σ atan(λ·u), u·Π (1 + (λ·u)²)^¼), remembered per u."""
        found = memo.get(u)
        if found is None:
            t = [v * u for v in lam]
            found = memo[u] = (0.5 * math.fsum(map(math.atan, t)), u * math.prod([(1.0 + s ** 2) ** 0.25 for s in t]))
        return found

    def head_part(u):
        if u > 0:
            a, r = angle_rho(u)
            return math.sin(a - w * u) / r
        return 0.5 * math.fsum(lam) - w

    def sin_part(u):
        a, r = angle_rho(u)
        return math.sin(a) / r

    def cos_part(u):
        a, r = angle_rho(u)
        return math.cos(a) / r

    head = quad(head_part, 0.0, 1.0, limit=200)[0]
    tail = (quad(sin_part, 1.0, np.inf, weight="cos", wvar=w)[0]
            - quad(cos_part, 1.0, np.inf, weight="sin", wvar=w)[0])
    return 0.5 + (head + tail) / math.pi


def norm_limit(S: np.ndarray, probability: float) -> float:
    """The length (mm) that a zero-mean Gaussian vector with covariance S stays below with
    `probability` (see the module)."""
    lam = np.clip(np.linalg.eigvalsh(np.atleast_2d(S)), 0.0, None)
    return _norm_limit_of(tuple(lam.tolist()), float(probability))


@functools.lru_cache(maxsize=4096)
def _norm_limit_of(eigenvalues: tuple, probability: float) -> float:
    """norm_limit for a covariance of these eigenvalues (mm²); a check series or a diagnosis
    asks again for the limits of the same poses and calibration, answered from the cache."""
    lam = np.array(eigenvalues)
    total, square = float(lam.sum()), float(np.sum(lam ** 2))
    if total <= 0.0:
        return 0.0
    c, nu = square / total, total ** 2 / square
    guess = c * chi2.ppf(probability, nu)
    lam = lam[lam > 1e-12 * lam.max()] / c          # scaled so the guess is near chi2 quantiles
    tail = 1.0 - probability
    memo: dict = {}                                  # the integrand's parts per u, shared by every x
    values: dict = {}                                # f per x: brentq asks again for the bracket's ends

    def f(x):
        if x not in values:
            values[x] = weighted_chi2_sf(x, lam, memo) - tail
        return values[x]

    lo, hi = 0.5 * guess / c, 2.0 * guess / c
    while f(hi) > 0:
        hi *= 2.0
    while f(lo) < 0 and lo > 1e-9:
        lo *= 0.5
    return math.sqrt(c * brentq(f, lo, hi, xtol=1e-10, rtol=1e-10))
