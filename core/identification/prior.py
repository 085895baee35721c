"""A prior toward the nominal geometry: Tikhonov (ridge) regularisation of the DH corrections.

Without a prior, identification keeps at nominal the parameters the measurements barely
determine (core.kinematics.identifiability.practical_identifiability). With a prior,
every structurally identifiable joint parameter is estimated instead, and the least-squares
cost gets a penalty that pulls the corrections toward the nominal values:

    Σ w·|x_measured − x_model|²  +  λ_L · Σ_lengths (Δg_i / 1 mm)²  +  λ_A · Σ_angles (Δg_i·reach)²

Δg_i is a joint parameter (θ, d, a, α, β) minus its nominal value; an angle counts as the
millimetres it moves a point at the robot's reach ("mm at the tool"). Without measurement
sigmas this is the maximum a-posteriori estimate with prior standard deviations σ̂/√λ_L mm per
length and σ̂/(√λ_A·reach) rad per angle (σ̂: the fit's residual standard deviation per axis);
with sigmas, 1/√λ of them. The base pose and the target offsets carry no prior: where the robot
stands and where an unmeasured target sits on the tool have no meaningful nominal value.
A given weight λ applies to both kinds (λ = 0 is the plain fit).

By default the two weights are estimated from the measurements by empirical Bayes (type-II
maximum likelihood, MacKay's evidence): the fit is linearised at its estimate, Δx ≈ Φ·δ, and
(λ_L, λ_A) maximise the marginal likelihood of the measurements with the corrections
integrated out — a flat prior on the base and the targets, the noise variance profiled:

    log p(Δx | λ) = −(m − r)/2·log C(λ) + ½·Σ_i log λ_i − ½·log det(ΦᵀWΦ + Λ) + const

(m equations, r parameters without a prior, C the penalised cost at the minimum, Λ the prior's
diagonal). The corrections the data determine well set how large a correction of each kind
typically is, and that sets how strongly the barely determined ones are pulled. The fit is
made again at the estimated weights until the estimate at a fit is within 5 % of that fit's own
weights, and that fit is the result: two or three fits in all (2.5 x the plain fit's time on the
bench), against 40 for the 5-fold cross validation of 8 weights used before.

Why not cross validation. Measured on the bench (bench/bench_identification.py prior_study,
10 runs; bench/bench_real_robot.py): 5-fold cross validation over 0, 1e-4 … 100 kept the plain
fit in nearly every run (prior / plain 0.9998 in the virtual lab, 0.9973 with the marker near
the last axis), because a prior had to beat it by two standard errors of the per-point
difference, and the gains (0.3–3 % of the cross-validated RMS) are far below the fold noise
(the 6R arm with its marker near the last axis, run 0: 0.1178 mm at λ = 0.01 against 0.1210 mm plain,
not significant). Dropping that rule does not help either: on the IRB 120 laser-tracker data,
cross validation on the calibration poses prefers λ = 1e-3 (0.1 % better, three seeds), but
that weight predicts the test points 1.9 % worse. One common weight estimated by the
evidence (0.00018) is also 0.3 % worse there: the robot's joint-zero offsets are degrees
(J4.θ −2.0°), its lengths tenths of a millimetre, and one scale for both pulls the offsets.
Separate weights for lengths and angles fix that (λ_L 0.19, λ_A 1e-4 on the IRB 120):
held-out mean error, prior / plain fit, over 10 seeded runs on the true robot — virtual lab
0.974 (runs 0.905–1.037), marker near the last axis 0.975 (0.878–1.009; 0.0461 against
0.0473 mm) — and on the IRB 120 test points 0.978 (0.3153 against 0.3224 mm).

The deflection terms (core.robot.compliance) are regularised by the same machinery: a ridge
toward the input model's coefficients (zero for a rigid one), weight λ_C per coefficient counted
like an angle (mm at the tool), estimated by the evidence together with (λ_L, λ_A) when those are
estimated too, or alone when the geometry has no prior (its parameters then have a flat prior).

How much of a parameter the data determine is the diagonal of the resolution matrix
(ΦᵀWΦ + Λ)⁻¹·ΦᵀWΦ: 1 when the measurements alone determine it, 0 when only the prior does.
Below DOMINATED_SHARE the parameter is reported as dominated by the prior.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable, Sequence

import numpy as np
from scipy.linalg import cho_factor, cho_solve

from core.errors import RoboCalError
from core.bounds import Bound
from core.kinematics.identifiability import column_scales
from core.kinematics.jacobian import COMPLIANCE, Parameter, compliance_value
from core.robot.model import RobotModel
from core.task import Monitor

#: the weight of the prior, as an option
WEIGHT = Bound(0.0, 1e6, "", "a prior weight above a million holds every DH value at nominal")
#: the range the estimated weights are searched in, and where the first linearisation is made
SEARCH = (1e-8, 1e6)
START_WEIGHT = 1e-3
#: fit again at the estimated weights until the estimate is within this factor of the fit's own weights
SETTLED = 1.05
ROUNDS = 4
#: a parameter whose data share is below this is dominated by the prior
DOMINATED_SHARE = 0.5
PRIOR_DOMINATED = "dominated by the prior"
EMPIRICAL_BAYES = "empirical Bayes"


@dataclass(frozen=True)
class PriorOptions:
    """The prior toward nominal: `weight` λ for lengths and angles alike (None: one weight for
    each kind, estimated by empirical Bayes)."""

    weight: float | None = None

    def __post_init__(self):
        if self.weight is not None:
            WEIGHT.check(self.weight, what="prior weight")


#: the kinds of parameters with a prior weight of their own
CATEGORIES = ("length", "angle", "compliance")


@dataclass(frozen=True)
class Weights:
    """λ_L for DH lengths, λ_A for DH angles, λ_C for deflection coefficients (all 0: the plain fit)."""

    length: float
    angle: float
    compliance: float = 0.0

    @property
    def plain(self) -> bool:
        return self.length <= 0 and self.angle <= 0 and self.compliance <= 0

    @property
    def geometric(self) -> bool:
        """A prior on the DH parameters (not only on the deflection terms)."""
        return self.length > 0 or self.angle > 0

    def replaced(self, values: dict) -> "Weights":
        return Weights(**{c: values.get(c, getattr(self, c)) for c in CATEGORIES})


def category(p: Parameter) -> str | None:
    """The weight a parameter's prior row takes: "length", "angle", "compliance", or None (no prior:
    base pose, target offsets, orientations)."""
    if p.group == "joint":
        return "angle" if p.angular else "length"
    return "compliance" if p.group == COMPLIANCE else None


def reach_mm(model: RobotModel) -> float:
    """Σ|a| + |d| of the joints plus the farthest target (mm), at least 1."""
    reach = sum(abs(j.a) + abs(j.d) for j in model.joints)
    reach += max((float(np.linalg.norm(t)) for t in model.targets.values()), default=0.0)
    return max(reach, 1.0)


@dataclass(frozen=True)
class PriorTerm:
    """The penalty rows for the free parameters: √λ·(g_nominal − g)/s per joint parameter and
    deflection coefficient (λ = the weight of its category; a category of weight 0 has no rows)."""

    nominal: RobotModel
    weights: Weights
    reach: float

    def weight_of(self, p: Parameter) -> float:
        c = category(p)
        return 0.0 if c is None else getattr(self.weights, c)

    def has_row(self, p: Parameter) -> bool:
        return self.weight_of(p) > 0

    def scales(self, free: Sequence[Parameter]) -> np.ndarray:
        """s_i per free parameter (internal units: mm, rad); inf for parameters without a prior."""
        return np.array([(1.0 / self.reach if p.angular else 1.0) if self.has_row(p) else np.inf for p in free])

    def deviations(self, model: RobotModel, free: Sequence[Parameter]) -> tuple[np.ndarray, np.ndarray]:
        """(indices into `free` of the parameters with a prior, their Δg/s)."""
        s = self.scales(free)
        idx = np.flatnonzero(np.isfinite(s))
        delta = np.array([_value(model, free[k]) - _value(self.nominal, free[k]) for k in idx])
        return idx, delta / s[idx] if len(idx) else np.zeros(0)

    def rows(self, model: RobotModel, free: Sequence[Parameter]) -> tuple[np.ndarray, np.ndarray]:
        """(J_p, b_p): Jacobian rows (k × p) and residuals (k,) of the penalty, one row per joint
        parameter, in the sign convention of the data rows (b = target − prediction)."""
        s = self.scales(free)
        idx, u = self.deviations(model, free)
        root = np.sqrt([self.weight_of(free[k]) for k in idx])
        J = np.zeros((len(idx), len(free)))
        J[np.arange(len(idx)), idx] = root / s[idx]
        return J, -root * u


def _value(model: RobotModel, p: Parameter) -> float:
    if p.group == COMPLIANCE:
        return compliance_value(model, p)
    return getattr(model.joints[p.joint], p.kind)


def data_share(J_data: np.ndarray, J_prior: np.ndarray) -> np.ndarray:
    """Diagonal of the resolution matrix (JᵀJ + J_pᵀJ_p)⁻¹·JᵀJ: the share of each parameter the
    data determine (1: data alone, 0: prior alone). Columns scaled to unit norm first."""
    D = np.linalg.norm(np.vstack([J_data, J_prior]), axis=0)
    D = np.where(D > 0, D, 1.0)
    Ad, Ap = J_data / D, J_prior / D
    G = Ad.T @ Ad
    H = G + Ap.T @ Ap
    return np.clip(np.diag(np.linalg.pinv(H, hermitian=True) @ G), 0.0, 1.0)


@dataclass
class PriorReport:
    """What the prior did: its weights, how they were chosen, and what it dominates."""

    weights: Weights
    chosen_by: str                       # "given" | EMPIRICAL_BAYES
    reach_mm: float
    sigma_hat: float                     # of the fit (mm per axis, or unitless with sigmas)
    shares: dict[str, float]             # joint parameter → data share

    @property
    def dominated(self) -> list[str]:
        return [n for n, s in self.shares.items() if s < DOMINATED_SHARE]

    @property
    def std_length_mm(self) -> float:
        """The prior's standard deviation of a DH length (mm; unitless factor with sigmas)."""
        w = self.weights.length
        return self.sigma_hat / math.sqrt(w) if w > 0 else math.inf

    @property
    def std_angle_deg(self) -> float:
        w = self.weights.angle
        return math.degrees(self.sigma_hat / math.sqrt(w) / self.reach_mm) if w > 0 else math.inf

    @property
    def weight_text(self) -> str:
        """"0.01", or "0.19 (lengths), 0.0001 (angles)"."""
        w = self.weights
        if w.length == w.angle:
            return f"{w.length:g}"
        return f"{w.length:.2g} (lengths), {w.angle:.2g} (angles)"

    def summary(self) -> dict:
        def fin(v):
            return v if math.isfinite(v) else None
        return {"weight_length": self.weights.length, "weight_angle": self.weights.angle,
                "chosen_by": self.chosen_by,
                "std_length_mm": fin(self.std_length_mm), "std_angle_deg": fin(self.std_angle_deg),
                "dominated": self.dominated, "data_share": dict(self.shares)}


@dataclass
class Linearised:
    """The fit at some weights, linearised: whitened data Jacobian J (m × p) and residual b (m,)
    at `model`, the free parameters in J's column order."""

    model: RobotModel
    free: list[Parameter]
    J: np.ndarray
    b: np.ndarray


def log_evidence(J: np.ndarray, b: np.ndarray, P: np.ndarray, c: np.ndarray) -> Callable[[np.ndarray], float]:
    """λ ↦ log marginal likelihood (up to a constant) of the linear model b ≈ J·δ with the prior
    c + P·δ ~ N(0, σ²/λ_i) per row i, a flat prior on the columns without a prior row, and σ²
    profiled out. P: (q × p) prior rows with unit weight, c: (q,) their values at δ = 0."""
    m, p = J.shape
    r = p - P.shape[0]
    D = column_scales(np.vstack([J, P]))
    D = np.where(np.isfinite(D), D, 1.0)
    Js, Ps = J / D, P / D
    G, g, bb = Js.T @ Js, Js.T @ b, float(b @ b)

    def value(lam: np.ndarray) -> float:
        H = G + Ps.T @ (lam[:, None] * Ps)
        try:
            factor = cho_factor(H)
        except (np.linalg.LinAlgError, ValueError):      # singular, or not finite
            return -math.inf
        rhs = g - Ps.T @ (lam * c)
        delta = cho_solve(factor, rhs)
        # C = |b − J·δ|² + Σ λ_i (c_i + P_i·δ)² at the minimum δ = H⁻¹·rhs
        cost = bb + float(np.sum(lam * c * c)) - float(rhs @ delta)
        logdet = 2.0 * float(np.sum(np.log(np.diag(factor[0]))))
        return -0.5 * (m - r) * math.log(max(cost, 1e-300)) + 0.5 * float(np.sum(np.log(lam))) - 0.5 * logdet
    return value


def evidence_weights(lin: Linearised, term: PriorTerm, search: Sequence[str] = ("length", "angle")) -> Weights:
    """The weights of the categories `search` (CATEGORIES) in SEARCH that maximise `log_evidence` at
    the linearisation `lin`, the other categories kept at `term`'s weights: a coarse log grid, then
    L-BFGS-B on log λ from its best point (deterministic)."""
    cats = [category(p) for p in lin.free]
    present = {c for c in cats if c is not None}
    kinds = [c for c in CATEGORIES if c in present and c in search]
    if not kinds:
        return term.weights
    with_rows = {c: (1.0 if c in kinds else getattr(term.weights, c)) for c in CATEGORIES}
    unit = PriorTerm(term.nominal, Weights(**{c: 1.0 if with_rows[c] > 0 else 0.0 for c in CATEGORIES}), term.reach)
    P, bp = unit.rows(lin.model, lin.free)
    idx, _ = unit.deviations(lin.model, lin.free)
    row_cat = [cats[k] for k in idx]
    lo, hi = (math.log(v) for v in SEARCH)
    evidence = log_evidence(lin.J, lin.b, P, -bp)

    def neg(x):
        value = {**{c: getattr(term.weights, c) for c in CATEGORIES}, **dict(zip(kinds, np.exp(x)))}
        return -evidence(np.array([value[c] for c in row_cat]))

    grid = np.linspace(lo, hi, 9)
    starts = np.array(np.meshgrid(*[grid] * len(kinds))).reshape(len(kinds), -1).T
    x0 = min(starts, key=lambda x: neg(x))
    if not math.isfinite(neg(x0)):
        raise RoboCalError("the prior's weights cannot be estimated from these measurements: some parameters "
                           "are determined neither by the measurements nor by the prior",
                           hint="Give the prior's weight (--prior WEIGHT) or fix those parameters.")
    from scipy.optimize import minimize         # 0.4 s to import, and every command's options import this module

    x = minimize(neg, x0, method="L-BFGS-B", bounds=[(lo, hi)] * len(kinds)).x
    return term.weights.replaced(dict(zip(kinds, np.exp(x).tolist())))


@dataclass
class WeightChoice:
    weights: Weights                     # of the last fit
    fits: int


def choose_weights(fit: Callable[[Weights, Monitor], Linearised], nominal: RobotModel, *,
                   monitor: Monitor | None = None, search: Sequence[str] = ("length", "angle"),
                   start: Weights | None = None) -> WeightChoice:
    """Empirical Bayes: fit at `start` (START_WEIGHT for the categories of `search`), estimate their
    weights by `evidence_weights` at that fit, and fit again at the estimate until the estimate
    at a fit is within SETTLED of the fit's own weights (at most ROUNDS fits). Returns the weights
    of the last fit, so that fit is the result."""
    monitor = monitor or Monitor()
    weights = (start or Weights(0.0, 0.0)).replaced({c: START_WEIGHT for c in search})
    reach = reach_mm(nominal)
    for n in range(1, ROUNDS + 1):
        sub = monitor.sub((n - 1) / ROUNDS, n / ROUNDS)
        sub.step(0.0, f"estimating the prior's weights: fit {n}")
        new = evidence_weights(fit(weights, sub), PriorTerm(nominal, weights, reach), search)
        if all(max(getattr(new, c) / getattr(weights, c), getattr(weights, c) / getattr(new, c)) < SETTLED
               for c in search):
            break
        if n < ROUNDS:
            weights = new
    return WeightChoice(weights, n)
