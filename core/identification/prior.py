"""A prior toward the nominal geometry: Tikhonov (ridge) regularisation of the DH corrections.

Without a prior, identification keeps at nominal the parameters the measurements barely
determine (core.identification.identifiability.practical_identifiability). With a prior of
weight λ > 0, every structurally identifiable joint parameter is estimated instead, and the
least-squares cost gets a penalty that pulls the corrections toward the nominal values:

    Σ w·|x_measured − x_model|²  +  λ · Σ_i (Δg_i / s_i)²

Δg_i is a joint parameter (θ, d, a, α, β) minus its nominal value; s_i = 1 mm for lengths and
1/reach rad for angles, so an angle correction counts as the millimetres it moves a point at
the robot's reach ("mm at the tool"). Without measurement sigmas this is the maximum a-posteriori
estimate with prior standard deviations σ̂/√λ mm per length and σ̂/(√λ·reach) rad per angle
(σ̂: the fit's residual standard deviation per axis); with sigmas, 1/√λ of them. The base pose
and the target offsets carry no prior: where the robot stands and where an unmeasured target
sits on the tool have no meaningful nominal value.

λ = 0 is the plain fit. By default λ is chosen among WEIGHTS (0 included) by k-fold cross
validation over the poses that are fitted: the weight whose models predict the left-out poses
best — but a prior replaces the plain fit only when it predicts them better by more than
SIGNIFICANCE standard errors of the paired per-point difference of squared errors (a prior
that wins by chance on the folds does not make new poses better).

How much of a parameter the data determine is the diagonal of the resolution matrix
(ΦᵀWΦ + λP)⁻¹·ΦᵀWΦ: 1 when the measurements alone determine it, 0 when only the prior does.
Below DOMINATED_SHARE the parameter is reported as dominated by the prior.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable, Sequence

import numpy as np

from core.bounds import Bound
from core.errors import RoboCalError
from core.identification.jacobian import Parameter, predict_points
from core.measurement.file import Measurements
from core.robot.model import RobotModel
from core.task import Monitor

#: the weights cross validation chooses from (0 = the plain fit)
WEIGHTS = (0.0, 1e-4, 1e-3, 1e-2, 1e-1, 1.0, 10.0, 100.0)
#: a prior must beat the plain fit by this many standard errors to replace it
SIGNIFICANCE = 2.0
#: a parameter whose data share is below this is dominated by the prior
DOMINATED_SHARE = 0.5
#: the weight of the prior, as an option
WEIGHT = Bound(0.0, 1e6, "", "a prior weight above a million holds every DH value at nominal")
CV_FOLDS = Bound(2, 100, "", "choosing the prior weight needs at least two folds")
PRIOR_DOMINATED = "dominated by the prior"


@dataclass(frozen=True)
class PriorOptions:
    """The prior toward nominal: `weight` λ (None: chosen by `folds`-fold cross validation
    among WEIGHTS)."""

    weight: float | None = None
    folds: int = 5

    def __post_init__(self):
        if self.weight is not None:
            WEIGHT.check(self.weight, what="prior weight")
        CV_FOLDS.check(self.folds, what="cross-validation folds for the prior")


def reach_mm(model: RobotModel) -> float:
    """Σ|a| + |d| of the joints plus the farthest target (mm), at least 1."""
    reach = sum(abs(j.a) + abs(j.d) for j in model.joints)
    reach += max((float(np.linalg.norm(t)) for t in model.targets.values()), default=0.0)
    return max(reach, 1.0)


@dataclass(frozen=True)
class PriorTerm:
    """The penalty rows for the free parameters: √λ·(g_nominal − g)/s per joint parameter."""

    nominal: RobotModel
    weight: float
    reach: float

    def scales(self, free: Sequence[Parameter]) -> np.ndarray:
        """s_i per free parameter (internal units: mm, rad); inf for parameters without a prior."""
        return np.array([(1.0 / self.reach if p.angular else 1.0) if p.group == "joint" else np.inf
                         for p in free])

    def rows(self, model: RobotModel, free: Sequence[Parameter]) -> tuple[np.ndarray, np.ndarray]:
        """(J_p, b_p): Jacobian rows (k × p) and residuals (k,) of the penalty, one row per joint
        parameter, in the sign convention of the data rows (b = target − prediction)."""
        s = self.scales(free)
        idx = np.flatnonzero(np.isfinite(s))
        root = math.sqrt(self.weight)
        J = np.zeros((len(idx), len(free)))
        J[np.arange(len(idx)), idx] = root / s[idx]
        delta = np.array([getattr(model.joints[free[k].joint], free[k].kind)
                          - getattr(self.nominal.joints[free[k].joint], free[k].kind) for k in idx])
        return J, -root * delta / s[idx] if len(idx) else np.zeros(0)


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
    """What the prior did: its weight, how it was chosen, and what it dominates."""

    weight: float
    chosen_by: str                       # "given" | "<k>-fold cross validation"
    reach_mm: float
    sigma_hat: float                     # of the fit (mm per axis, or unitless with sigmas)
    shares: dict[str, float]             # joint parameter → data share
    cv_rms_mm: dict[float, float] = field(default_factory=dict)   # weight → cross-validated RMS

    @property
    def dominated(self) -> list[str]:
        return [n for n, s in self.shares.items() if s < DOMINATED_SHARE]

    @property
    def std_length_mm(self) -> float:
        """The prior's standard deviation of a DH length (mm; unitless factor with sigmas)."""
        return self.sigma_hat / math.sqrt(self.weight) if self.weight > 0 else math.inf

    @property
    def std_angle_deg(self) -> float:
        return math.degrees(self.std_length_mm / self.reach_mm)

    def summary(self) -> dict:
        def fin(v):
            return v if math.isfinite(v) else None
        return {"weight": self.weight, "chosen_by": self.chosen_by,
                "std_length_mm": fin(self.std_length_mm), "std_angle_deg": fin(self.std_angle_deg),
                "dominated": self.dominated, "data_share": dict(self.shares),
                "cross_validation_rms_mm": {f"{w:g}": fin(r) for w, r in self.cv_rms_mm.items()}}


@dataclass
class WeightChoice:
    weight: float
    rms_mm: dict[float, float]           # weight → cross-validated RMS (inf: the fit failed)
    folds: int


def choose_weight(meas: Measurements, fit: Callable[[Measurements, float, Monitor], RobotModel], *,
                  folds: int = 5, seed: int = 0, weights: Sequence[float] = WEIGHTS,
                  monitor: Monitor | None = None) -> WeightChoice:
    """The weight among `weights` whose models, fitted by `fit(training, weight, monitor)` on
    all but one of `folds` seeded random groups of poses, predict the left-out poses with the
    smallest RMS error. Points of targets absent from a fold's training poses are not scored."""
    from core.identification.solver import kfold_poses    # solver imports this module
    monitor = monitor or Monitor()
    ids = list(meas.pose_ids)
    k = min(int(folds), len(ids))
    if k < 2:
        raise RoboCalError("too few poses to choose the prior weight by cross validation",
                           source=meas.source or None, hint="Measure more poses or give the weight.")
    groups = kfold_poses(ids, k, seed)
    rms: dict[float, float] = {}
    squared: dict[float, np.ndarray] = {}         # per scored point, for the paired comparison
    n_runs = len(weights) * k
    for w_i, weight in enumerate(weights):
        sq: list[np.ndarray] = []
        for f, test_ids in enumerate(groups):
            run = w_i * k + f
            sub = monitor.sub(run / n_runs, (run + 1) / n_runs)
            sub.step(0.0, f"choosing the prior weight: {weight:g}, fold {f + 1} of {k}")
            train = meas.select_poses([p for p in ids if p not in set(test_ids)])
            test = meas.select_poses(test_ids)
            try:
                model = fit(train, float(weight), sub)
            except RoboCalError:
                sq = []
                break
            keep = np.isin(np.asarray(test.target), list(set(train.target)))
            names = [t for t, ok in zip(test.target, keep) if ok]
            if names:
                e = test.xyz[keep] - predict_points(model, test.Q[keep], names)
                sq.append(np.sum(e ** 2, axis=1))
        if sq:
            squared[float(weight)] = np.concatenate(sq)
            rms[float(weight)] = math.sqrt(float(squared[float(weight)].mean()))
        else:
            rms[float(weight)] = math.inf
    plain = squared.get(0.0)

    def significant(w: float) -> bool:
        if w == 0.0 or plain is None:
            return True
        d = squared[w] - plain
        return float(d.mean()) + SIGNIFICANCE * float(d.std(ddof=1)) / math.sqrt(len(d)) < 0.0

    finite = [w for w in rms if math.isfinite(rms[w]) and significant(w)]
    best = min(finite, key=lambda w: (rms[w], w)) if finite else None
    if best is None:
        raise RoboCalError("no prior weight could be cross validated: every fold's fit failed",
                           source=meas.source or None, hint="Measure more poses or give the weight.")
    return WeightChoice(best, rms, k)
