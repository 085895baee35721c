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
one with the smallest Akaike criterion AIC = RSS_K + 2·p_K; "several" when no simple set passes. When even "several" leaves a residual beyond its limit
(RSS_F/(3N − p_F) against F(3N − p_F, m − p), m − p the calibration's degrees of freedom, as S
scales with its σ̂²), no candidate explains the check (the geometry changed in another way,
e.g. a bent link) and the advice is a full calibration.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

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

    sigma_dof: float = math.inf   # degrees of freedom of the calibration's σ̂

    @property
    def fit_probability(self) -> float:
        """Probability of a residual this large if this candidate were the whole change: the
        weighted residual per degree of freedom against F(3N − p, calibration's m − p), as S
        scales with the calibration's estimated σ̂² (χ² when σ is known)."""
        dof = self.n - self.p
        if dof <= 0:
            return 1.0
        if math.isinf(self.sigma_dof):
            return float(chi2.sf(self.rss, dof))
        return float(f_dist.sf(self.rss / dof, dof, self.sigma_dof))

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
    explained: bool           # the chosen set fits the check within its χ² limit
    text: str
    alpha: float
    full_calibration: bool = False
    notes: list[str] = field(default_factory=list)

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
                "change": self.chosen.change(),
                "candidates": [{"kind": f.kind, "label": f.label, "rss": f.rss, "p": f.p,
                                "nested_probability": f.nested_probability} for f in self.fits]}


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
    S = prediction_covariance(model, unc, Q, targets)
    L = cho_factor(S, lower=True)[0]
    L = np.tril(L)
    rw = solve_triangular(L, e, lower=True)
    fits = []
    for kind, label, params, joint in candidate_sets(model, target):
        J = calibration_jacobian(model, Q, targets, params) if params else np.zeros((len(e), 0))
        Jw = solve_triangular(L, J, lower=True) if params else J
        delta, rss, rank = _fit(rw, Jw)
        explained = float(np.sqrt(np.mean(np.sum((J @ delta).reshape(-1, 3) ** 2, axis=1)))) if params else 0.0
        fits.append(CandidateFit(kind, label, list(params), delta, rss, rank, len(e), joint, explained, unc.dof))
    full = next(f for f in fits if f.kind == SEVERAL)
    dof_full = full.n - full.p
    for f in fits:
        if f is not full and full.p > f.p and dof_full > 0:
            stat = ((f.rss - full.rss) / (full.p - f.p)) / max(full.rss / dof_full, 1e-300)
            f.nested_probability = float(f_dist.sf(stat, full.p - f.p, dof_full))
    fits.sort(key=lambda f: (f.nested_probability < alpha, f.kind != NONE, f.kind == SEVERAL, f.aic, f.p))
    chosen = fits[0]
    explained = full.fit_probability >= alpha
    text, full_calibration = describe(chosen, explained, model)
    return Diagnosis(fits, chosen, explained, text, alpha, full_calibration=full_calibration)


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


def describe(fit: CandidateFit, explained: bool, model: RobotModel) -> tuple[str, bool]:
    """The plain-language result, and whether a full calibration is advised."""
    if not explained:
        return ("The errors fit none of the simple changes (marker on the tool, robot base, one joint's "
                "zero): the geometry changed in another way or in several places. Run a full calibration."), True
    change = fit.change()
    if fit.kind == NONE:
        return "No change found: the errors are within what the calibration predicts.", False
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
