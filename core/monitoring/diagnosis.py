"""Which change explains a check that left its limits.

Small candidate parameter sets are fitted to the check's errors e = measured − predicted, each
by generalised least squares with the predicted covariance S of the errors (core.monitoring.
uncertainty): whitened with S = L·Lᵀ, the fit of set K minimises |L⁻¹(e − Φ_K·δ)|², and with
no change that weighted residual sum RSS_K follows χ² with 3N − p_K degrees of freedom.

Candidates: no change; the target offset on the tool (a tool change or a bent tool, 3
parameters); the base pose in the camera frame (the robot or the cameras moved, 6); each joint's
zero offset alone (an encoder slipped, 1); and all of these together ("several", p_F = the
number the check poses determine). Each simple set K is nested in "several", so the nested
F-test  F = ((RSS_K − RSS_F)/(p_F − p_K)) / (RSS_F/(3N − p_F))  against F(p_F − p_K, 3N − p_F)
says whether K explains the errors as well as everything together (the ratio does not depend on
σ). The diagnosis is "no change" when that passes at `alpha`, else among the sets that pass the
one with the smallest Akaike criterion AIC = RSS_K + 2·p_K; "several" when no simple set passes.

When even "several" leaves a residual beyond what the calibration predicts, no candidate
explains the check (the geometry changed in another way, e.g. a bent link) and the advice is a
full calibration. Image location errors have heavy tails (a few points at 3–5 σ), which fail a
plain χ²/F test of RSS_F after a simple change; so this absolute test first sets aside up to k
outlying points (k = TRIMMED_POINTS = 2, fewer when fewer than MIN_TRIMMED_DOF degrees of freedom
would be left or more than MAX_TRIMMED_SETS sets searched) by a forward search, then judges
the rest:
- with P = S⁻¹ − S⁻¹Φ(ΦᵀS⁻¹Φ)⁺ΦᵀS⁻¹ (Φ the Jacobian of "several", rank p_F), RSS_F = eᵀPe and
  u = P·e, leaving out the rows D of a set of points is exactly fitting "several" to the other
  points alone (their own block of S): RSS_D = RSS_F − u_Dᵀ·P_DD⁺·u_D, with
  ν_D = 3N − p_F − rank(P_DD) degrees of freedom;
- step s + 1 of the search leaves out, besides the s points already set aside, the one whose
  removal lowers RSS most, if that drop exceeds the step's limit c_(s+1): the drop that the null
  draws reaching that step exceed with probability FLAG_RATE (5 %; with no outlier a point is set
  aside in about 5 % of checks);
- the statistic is T = RSS_D / ν_D for the set D the search ended with (D empty: RSS_F/(3N − p_F)).
Its null distribution (Gaussian errors with covariance S, nothing but "several" changed) is that
of T(s·L·z), z ~ N(0, I_3N), S = L·Lᵀ, s² = ν/χ²_ν the scatter of the calibration's σ̂ (S scales
with σ̂², ν = m − p its degrees of freedom; s = 1 when σ is known), the same search and limits
applied to each draw: NULL_DRAWS draws (fixed seed: a diagnosis is repeatable), p-value
(1 + #{T_null ≥ T})/(1 + NULL_DRAWS) (with k = 0: F(3N − p_F, ν), χ² when σ is known).
"Unexplained" when it is below alpha: false alarms at the rate alpha under Gaussian errors (up
to the Monte Carlo error ±√(α/NULL_DRAWS)); up to k outlying points, set aside, do not decide it,
while a change of the geometry (a bent link) leaves large residuals at the points kept. An
outlier not large enough to be set aside weighs more than in the plain test (a large RSS with
no point standing out is what a systematic change gives).
"""
from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field
from itertools import combinations

import numpy as np
from scipy.linalg import cho_factor, solve_triangular
from scipy.stats import chi2
from scipy.stats import f as f_dist

from core.kinematics.jacobian import Parameter, calibration_jacobian
from core.monitoring.check import CheckResult
from core.monitoring.check_poses import watched_parameters
from core.monitoring.uncertainty import CalibrationUncertainty, prediction_covariance
from core.robot.model import RobotModel

NONE, TOOL, BASE, JOINT, SEVERAL = "none", "tool", "base", "joint", "several"
TRIMMED_POINTS = 2          # check points the absolute test may set aside at most (the outlying ones)
MIN_TRIMMED_DOF = 3         # degrees of freedom left at least once they are set aside (else fewer)
MAX_TRIMMED_SETS = 500      # sets of points searched at most (else fewer set aside)
FLAG_RATE = 0.05            # probability under the null that a step of the search sets a point aside
NULL_DRAWS = 4000           # draws of the trimmed statistic's null distribution
NULL_SEED = 0


@dataclass
class CandidateFit:
    """One candidate set fitted to the check's errors."""

    kind: str                 # none | tool | base | joint | several
    label: str                # words for a technician
    parameters: list[Parameter]
    delta: np.ndarray         # estimated change of each parameter (internal units: mm, rad)
    rss: float                # whitened residual sum of squares (unitless)
    p: int                    # parameters the check poses determine (rank)
    n: int                    # whitened equations (3 per point)
    joint: int = -1           # 0-based joint for kind "joint"
    explained_mm: float = 0.0  # RMS over the check points of the error the change explains (mm)

    nested_probability: float = 1.0   # the nested F-test's p-value against "several"

    @property
    def aic(self) -> float:
        """Akaike's criterion with σ known: RSS + 2·p."""
        return self.rss + 2.0 * self.p

    @property
    def noise_scale(self) -> float:
        """How much the check's points err beyond the predicted covariance once this change is
        fitted: √(RSS / (3N − p)), at least 1 (1 when no degree of freedom is left)."""
        dof = self.n - self.p
        return max(1.0, math.sqrt(self.rss / dof)) if dof > 0 else 1.0

    @property
    def names(self) -> list[str]:
        return [p.name for p in self.parameters]

    def change(self) -> dict[str, float]:
        """The estimated change per parameter in file units (mm / deg)."""
        return {p.name: float(d * p.to_display) for p, d in zip(self.parameters, self.delta)}


@dataclass
class Diagnosis:
    """The candidates (the chosen first, then by fewest parameters), the chosen one and a
    plain-language result."""

    fits: list[CandidateFit]
    chosen: CandidateFit
    explained: bool           # "several" fits the check within its limit (the absolute test, see the module)
    text: str
    alpha: float
    full_calibration: bool = False
    notes: list[str] = field(default_factory=list)
    absolute: "AbsoluteTest | None" = None

    @property
    def kind(self) -> str:
        return self.chosen.kind if self.explained else SEVERAL

    @property
    def parameters(self) -> list[Parameter]:
        """What a re-identification should re-estimate (empty when nothing changed)."""
        return list(self.chosen.parameters)

    def summary(self) -> dict:
        return {"kind": self.kind, "text": self.text, "explained": self.explained,
                "full_calibration": self.full_calibration, "changed": self.chosen.names,
                "fit_probability": self.absolute.probability if self.absolute else None,
                "set_aside": self.absolute.set_aside if self.absolute else [],
                "change": self.chosen.change(),
                "candidates": [{"kind": f.kind, "label": f.label, "rss": f.rss, "p": f.p,
                                "nested_probability": f.nested_probability} for f in self.fits]}


@dataclass
class AbsoluteTest:
    """Whether "several" explains the check, its worst-fitting points set aside (see the module)."""

    probability: float        # p-value of the trimmed statistic under the null
    statistic: float          # T: weighted residual per degree of freedom with the points set aside
    set_aside: list[int]      # the points set aside (indices in the check's points), the worst fitting
    trimmed: int              # k: how many points are set aside
    dof: int                  # 3N − p_F − 3k: degrees of freedom of the trimmed fit (at full rank)


def residual_maker(L: np.ndarray, Jw: np.ndarray) -> np.ndarray:
    """P = L⁻ᵀ(I − UUᵀ)L⁻¹ (3N × 3N, mm⁻²), U an orthonormal basis of the whitened Jacobian Jw's
    columns (rank as the fits take it): eᵀPe is the weighted residual sum of the fit of Jw."""
    A = solve_triangular(L, np.eye(len(L)), lower=True)
    if Jw.shape[1]:
        scale = np.linalg.norm(Jw, axis=0)
        U, sv, _ = np.linalg.svd(Jw / np.where(scale > 0, scale, 1.0), full_matrices=False)
        U = U[:, sv > 1e-8 * sv[0]] if sv.size and sv[0] > 0 else U[:, :0]
        return A.T @ (A - U @ (U.T @ A))
    return A.T @ A


def absolute_test(e: np.ndarray, L: np.ndarray, Jw: np.ndarray, p: int, sigma_dof: float, *,
                  most: int = TRIMMED_POINTS) -> AbsoluteTest:
    """The test of the fit of Jw (the whitened Jacobian of "several", rank p) to the errors e (3N,
    mm), S = L·Lᵀ, the calibration's σ̂ with `sigma_dof` degrees of freedom, up to `most`
    outlying points set aside (see the module)."""
    n = len(e)
    dof = n - p
    if dof <= 0:
        return AbsoluteTest(1.0, 0.0, [], 0, max(dof, 0))
    k = max(0, min(most, n // 3 - 1, (dof - MIN_TRIMMED_DOF) // 3))
    while k > 0 and math.comb(n // 3, k) > MAX_TRIMMED_SETS:
        k -= 1
    if k == 0:
        stat = float(e @ residual_maker(L, Jw) @ e) / dof
        prob = chi2.sf(stat * dof, dof) if math.isinf(sigma_dof) else f_dist.sf(stat, dof, sigma_dof)
        return AbsoluteTest(float(prob), stat, [], 0, dof)
    sets, limits, null_stat = _null_distribution(L, Jw, k, dof, sigma_dof)
    (stat,), (aside,) = sets.statistic(e[:, None], limits)
    prob = (1 + int(np.count_nonzero(null_stat >= stat))) / (1 + NULL_DRAWS)
    return AbsoluteTest(prob, float(stat), list(aside), len(aside), dof - 3 * len(aside))


NULLS_KEPT = 8                      # null distributions remembered, the least recently used forgotten first


def _null_distribution(L: np.ndarray, Jw: np.ndarray, k: int, dof: int, sigma_dof: float):
    """The point sets, flag limits and null statistics of the absolute test for S = L·Lᵀ and Jw: a
    function of these alone (seeded draws), so computed once for the errors of several checks
    judged against the same calibration and hypothesis."""
    L, Jw = np.ascontiguousarray(L), np.ascontiguousarray(Jw)
    return _null_distribution_of((L.shape, L.dtype.str, L.tobytes()), (Jw.shape, Jw.dtype.str, Jw.tobytes()),
                                 k, dof, float(sigma_dof))


@functools.lru_cache(maxsize=NULLS_KEPT)
def _null_distribution_of(L_key: tuple, Jw_key: tuple, k: int, dof: int, sigma_dof: float):
    """_null_distribution of the matrices given as (shape, dtype, bytes)."""
    L, Jw = (np.frombuffer(data, dtype=dtype).reshape(shape) for shape, dtype, data in (L_key, Jw_key))
    n = len(L)
    sets = _PointSets(residual_maker(L, Jw), n // 3, k, dof)
    rng = np.random.default_rng(NULL_SEED)
    null = L @ rng.standard_normal((n, NULL_DRAWS))
    if not math.isinf(sigma_dof):
        null *= np.sqrt(sigma_dof / rng.chisquare(sigma_dof, NULL_DRAWS))
    limits = sets.flag_limits(null)
    null_stat, _ = sets.statistic(null, limits)
    return sets, limits, null_stat


class _PointSets:
    """The forward search of the absolute test over every set of up to k of N points: for errors E
    (3N, B columns) the drop of the weighted residual sum when a set D is left out, u_Dᵀ·P_DD⁺·u_D
    (u = P·E), and its degrees of freedom rank(P_DD)."""

    def __init__(self, P: np.ndarray, points: int, k: int, dof: int):
        self.P, self.points, self.k, self.dof = P, points, k, dof
        tol = 1e-9 * float(np.abs(np.diag(P)).max())
        self.sets = [[()]]                  # sets[s]: every set of s points, in order
        self.blocks = [[]]                  # blocks[s]: (rows, P_DD⁺) per set
        self.rank = [np.zeros(1, int)]      # rank[s]: rank(P_DD) per set
        self.grown = []                     # grown[s][i, j]: the index in sets[s+1] of sets[s][i] ∪ {j} (-1: j in it)
        for s in range(1, k + 1):
            sets = list(combinations(range(points), s))
            index = {d: i for i, d in enumerate(sets)}
            blocks, rank = [], []
            for d in sets:
                rows = np.array([3 * i + a for i in d for a in range(3)])
                w, V = np.linalg.eigh(P[np.ix_(rows, rows)])
                keep = w > tol
                blocks.append((rows, (V[:, keep] / w[keep]) @ V[:, keep].T))
                rank.append(int(keep.sum()))
            self.grown.append(np.array([[index.get(tuple(sorted(d + (j,))), -1) if j not in d else -1
                                         for j in range(points)] for d in self.sets[-1]]))
            self.sets.append(sets)
            self.blocks.append(blocks)
            self.rank.append(np.array(rank))

    def _drops(self, E: np.ndarray) -> tuple[np.ndarray, list[np.ndarray]]:
        U = self.P @ E
        rss = np.einsum("ij,ij->j", E, U)
        drops = [np.zeros((1, E.shape[1]))]
        for blocks in self.blocks[1:]:
            drops.append(np.array([np.einsum("ij,ij->j", U[rows], G @ U[rows]) for rows, G in blocks]))
        return rss, drops

    def _search(self, E: np.ndarray, drops: list[np.ndarray], limits: list[float]):
        """Per column of E: the gain of each step of the search, the set it reached (its index and
        size). A step leaves out the point whose removal lowers the residual most, while that drop
        is above the step's limit."""
        cols = np.arange(E.shape[1])
        at = np.zeros(E.shape[1], int)           # index in sets[size] of each column's set
        size = np.zeros(E.shape[1], int)
        going = np.ones(E.shape[1], bool)
        gains = []
        for s in range(self.k):
            nxt = self.grown[s][at]                                          # (B, N)
            extra = np.where(nxt >= 0, drops[s + 1][np.maximum(nxt, 0), cols[:, None]], -np.inf)
            best = np.argmax(extra, axis=1)
            gain = extra[cols, best] - drops[s][at, cols]
            gains.append(np.where(going, gain, np.nan))
            going &= gain > limits[s]
            at = np.where(going, nxt[cols, best], at)
            size += going
        return gains, at, size

    def flag_limits(self, null: np.ndarray) -> list[float]:
        """The drop above which each step of the search leaves a point out: exceeded with
        probability FLAG_RATE under the null by the draws that reached that step."""
        _, drops = self._drops(null)
        limits: list[float] = []
        for s in range(self.k):
            gains, _, _ = self._search(null, drops, limits + [-np.inf] * (self.k - s))
            reached = gains[s][~np.isnan(gains[s])]
            limits.append(float(np.quantile(reached, 1.0 - FLAG_RATE)) if reached.size else np.inf)
        return limits

    def statistic(self, E: np.ndarray, limits: list[float]) -> tuple[np.ndarray, list[tuple[int, ...]]]:
        """T per column of E: the weighted residual per degree of freedom once the points the
        search flagged are left out; and those points."""
        rss, drops = self._drops(E)
        _, at, size = self._search(E, drops, limits)
        cols = np.arange(E.shape[1])
        drop = np.array([drops[z][a, c] for z, a, c in zip(size, at, cols)])
        nu = np.array([self.dof - self.rank[z][a] for z, a in zip(size, at)], dtype=float)
        return np.maximum(rss - drop, 0.0) / np.maximum(nu, 1.0), [self.sets[z][a] for z, a in zip(size, at)]


def tool_words(model: RobotModel, target: str) -> str:
    """"the tool", or "the tool 'NAME'" when the robot has several (the one carrying `target`)."""
    return f"the tool '{model.tool_of(target)}'" if len(model.tool_map()) > 1 else "the tool"


def candidate_sets(model: RobotModel, target: str) -> list[tuple[str, str, list[Parameter], int]]:
    """(kind, label, parameters, joint) of every candidate change; the tool offset is that of the
    mounted tool, the one carrying the check's `target`."""
    watched = watched_parameters(model, [target])
    out = [(NONE, "no change", [], -1),
           (TOOL, f"the marker on {tool_words(model, target)}", [p for p in watched if p.group == "target"], -1),
           (BASE, "the robot base relative to the cameras", [p for p in watched if p.group == "base"], -1)]
    for p in watched:
        if p.group == "joint":
            out.append((JOINT, f"joint {p.joint + 1}'s zero", [p], p.joint))
    out.append((SEVERAL, "several things", watched, -1))
    return out


def _fit(rw: np.ndarray, Jw: np.ndarray) -> tuple[np.ndarray, float, int]:
    if Jw.shape[1] == 0:
        return np.zeros(0), float(rw @ rw), 0
    scale = np.linalg.norm(Jw, axis=0)
    scale = np.where(scale > 0, scale, 1.0)
    x, _, rank, _ = np.linalg.lstsq(Jw / scale, rw, rcond=1e-8)
    delta = x / scale
    r = rw - Jw @ delta
    return delta, float(r @ r), int(rank)


def diagnose(model: RobotModel, unc: CalibrationUncertainty, check: CheckResult, *,
             alpha: float | None = None) -> Diagnosis:
    """Fit every candidate change to `check`'s errors and choose by the nested F-test (see the module)."""
    alpha = check.alpha if alpha is None else float(alpha)
    if not check.points:
        raise ValueError("a check without points cannot be diagnosed")
    target = check.points[0].target
    Q, targets, e = check.Q, check.targets, check.residuals
    S = prediction_covariance(model, unc, Q, targets, check.covariances)
    L = cho_factor(S, lower=True)[0]
    L = np.tril(L)
    rw = solve_triangular(L, e, lower=True)
    fits = []
    for kind, label, params, joint in candidate_sets(model, target):
        J = calibration_jacobian(model, Q, targets, params) if params else np.zeros((len(e), 0))
        Jw = solve_triangular(L, J, lower=True) if params else J
        delta, rss, rank = _fit(rw, Jw)
        explained = float(np.sqrt(np.mean(np.sum((J @ delta).reshape(-1, 3) ** 2, axis=1)))) if params else 0.0
        fits.append(CandidateFit(kind, label, list(params), delta, rss, rank, len(e), joint, explained))
        if kind == SEVERAL:
            absolute = absolute_test(e, L, Jw, rank, unc.dof)
    full = next(f for f in fits if f.kind == SEVERAL)
    dof_full = full.n - full.p
    for f in fits:
        if f is not full and full.p > f.p and dof_full > 0:
            stat = ((f.rss - full.rss) / (full.p - f.p)) / max(full.rss / dof_full, 1e-300)
            f.nested_probability = float(f_dist.sf(stat, full.p - f.p, dof_full))
    fits.sort(key=lambda f: (f.nested_probability < alpha, f.kind != NONE, f.kind == SEVERAL, f.aic, f.p))
    chosen = fits[0]
    explained = absolute.probability >= alpha
    text, full_calibration = describe(chosen, explained, model, check)
    return Diagnosis(fits, chosen, explained, text, alpha, full_calibration=full_calibration, absolute=absolute)


def _out_without_a_change(check: CheckResult) -> str:
    """Words for a check out of limits that no change explains better than none: the poses
    beyond their own limits stand alone, or the errors are a little too large everywhere."""
    lead = "No change of the tool, the base or a joint's zero explains this check"
    out = [p for p in check.points if not p.within]
    if out:
        names = [str(p.pose) for p in out]
        poses = names[0] if len(names) == 1 else ", ".join(names[:-1]) + " and " + names[-1]
        beyond = ", ".join(f"{p.error_mm - p.limit_mm:.3f}" for p in out)
        return (f"{lead}: only pose{'s' if len(out) > 1 else ''} {poses} {'are' if len(out) > 1 else 'is'} beyond "
                f"{'their' if len(out) > 1 else 'its'} limit (by {beyond} mm), and the other poses agree with the "
                "calibration. A marker measured badly there (seen at a steep angle, partly covered, a reflection) "
                "does this: run the check again. If the same poses stay out of limits, run a full calibration.")
    return (f"{lead}: the errors are spread over every pose, a little larger than the calibration predicts "
            f"({check.rms_mm:.3f} mm RMS, limit {check.rms_limit_mm:.3f} mm). Run the check again; if it stays out "
            "of limits, run a full calibration.")


def _unchanged(kind: str, joint: int = -1) -> str:
    if kind == TOOL:
        return "base and joints unchanged"
    if kind == BASE:
        return "tool and joints unchanged"
    return "tool, base and the other joints unchanged"


def _tool_cause(model: RobotModel) -> str:
    if len(model.tool_map()) > 1:
        return "another tool mounted than the one checked, a tool change or a bent tool"
    return "a tool change or a bent tool"


def describe(fit: CandidateFit, explained: bool, model: RobotModel, check: CheckResult) -> tuple[str, bool]:
    """The plain-language result for `check`, and whether a full calibration is advised."""
    if not explained:
        return ("The errors fit none of the simple changes (marker on the tool, robot base, one joint's "
                "zero): the geometry changed in another way or in several places. Run a full calibration."), True
    change = fit.change()
    if fit.kind == NONE:
        if check.within:
            return "No change found: the errors are within what the calibration predicts.", False
        return _out_without_a_change(check), False
    if fit.kind == TOOL:
        d = np.array([v for k, v in change.items()])
        axes = ", ".join(f"{a} {v:+.2f}" for a, v in zip("xyz", d))
        return (f"The marker moved {np.linalg.norm(d):.1f} mm on {tool_words(model, fit.parameters[0].target)} "
                f"({axes} mm in the tool frame): {_tool_cause(model)}; {_unchanged(TOOL)}."), False
    if fit.kind == BASE:
        shift = math.sqrt(sum(change[f"base.{a}"] ** 2 for a in "xyz"))
        turn = math.sqrt(sum(change[f"base.r{a}"] ** 2 for a in "xyz"))
        return (f"The robot base moved {shift:.1f} mm and turned {turn:.2f}° relative to the cameras: the robot "
                f"or the cameras moved; {_unchanged(BASE)}."), False
    if fit.kind == JOINT:
        (name, value), = change.items()
        unit = "°" if fit.parameters[0].angular else " mm"
        return (f"Joint {fit.joint + 1}'s zero shifted by {value:+.2f}{unit} (an encoder slipped or the joint was "
                f"homed again); {_unchanged(JOINT)}."), False
    return ("Several things changed at once (the marker, the base and joint zeros together explain the errors; "
            "no single one does). Run a full calibration, or re-identify all of them from the proposed poses."), True
