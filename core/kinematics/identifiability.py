"""Identifiability of the parameters g, and observability indices of Φ.

Column scaling. Φ mixes mm/mm columns (lengths) and mm/rad columns (angles), so every rank,
condition number and index here is computed on the column-scaled Φ_s = Φ·D⁻¹ with D the
column norms (unless other scales are given): each column then has unit norm, and a small
singular value means a combination of parameters that barely moves the measured points.

Which parameters are identified (`analyse`), in three layers:
1. fixed by the user (`--fix J2.a,base.rz`): kept at the nominal value;
2. Hayati: for joints whose axis is parallel to the next, `Ji.d` is kept fixed and `Ji.beta`
   added (see core.kinematics.jacobian for why this d);
3. structural: Φ_s is built for many random configurations (so no dependency is an accident
   of the pose set) and its numerical rank r found by SVD. Parameters are then removed one by
   one in a fixed preference order — joint parameters from the last joint to the first, then
   target offsets, then the base — whenever removing one keeps the rank r, until r remain.
   (A column-pivoted QR picks by column norm, which on a unit-norm Φ_s is arbitrary; the
   ordered elimination keeps the parameters a user expects to see estimated: the base pose
   absorbs J1.theta and J1.d, the target offsets absorb the last joint's parameters.) Each
   removed parameter is explained with the parameters that absorb it (its column regressed on
   the kept ones).
The structural analysis holds at the geometry it is done at; a nominal model has special
values (a marker exactly on the last axis, a = 0 exactly) that create dependencies a real robot
does not have. `core.identification.fit` therefore analyses twice: at the start (the nominal
model, a safe reduced set for the first fit) and again at that first estimate, where
`practical_identifiability` also removes parameters the measurements determine so poorly that
their expected standard deviation exceeds 1° or 5 mm (e.g. the last joint's angle when the
marker sits almost on its axis).
Then `check_data` tests the measured poses: if their Φ_s is rank deficient on the remaining
parameters, the data cannot determine them and the message says which joints to move and how
many poses to take.

Observability indices (Sun & Hollerbach, "Observability index selection for robot
calibration", ICRA 2008), with σ_1 ≥ … ≥ σ_L the singular values of the scaled Φ (L
parameters) and m the number of measured points:
    O1 = (σ_1·σ_2·…·σ_L)^(1/L) / √m      (Borm & Menq, D-optimal: grows as the error ellipsoid shrinks)
    O2 = σ_L / σ_1                        (Driels & Pathre: inverse condition number)
    O3 = σ_L                              (Nahvi et al.: minimum singular value, E-optimal)
    O4 = σ_L² / σ_1                       (Nahvi & Hollerbach: noise amplification index)
    O5 = 1 / Σ 1/σ_i²                      (Sun & Hollerbach: A-optimal)
Larger is better for all five. The condition number is σ_1/σ_L.
For comparing pose sets (core.poses.selection), pass the same fixed `scales` to every candidate (e.g.
`characteristic_scales`), since scaling each candidate by its own column norms changes the
yardstick between candidates.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Iterable, Sequence

import numpy as np

from core.errors import RoboCalError
from core.kinematics.jacobian import (Parameter, all_parameters, calibration_jacobian, expand_poses, hayati_joints,
                                      joint_label, resolve_names)
from core.kinematics.orientation import STRUCTURAL_ROW_SCALE, has_orientation_parameters, orientation_jacobian
from core.robot.model import RobotModel

RANK_TOL = 1e-9          # relative singular value below which a direction is structurally null
DATA_RANK_TOL = 1e-8     # … or not determined by the measured poses
STRUCTURAL_POSES = 60    # random configurations for the structural analysis

# a parameter's status in the parameter table
IDENTIFIED = "identified"
FIXED_BY_USER = "fixed by user"
HAYATI = "fixed (Hayati)"
NOT_IDENTIFIABLE = "not identifiable"
NOT_DETERMINED = "not determined by the measurements"
# A parameter whose expected std would exceed these is "practically" not identifiable.
# (1° moves a point 300 mm away by 5 mm; calibration corrections are typically 0.1° and 1 mm.)
PRACTICAL_ANGLE_LIMIT_DEG = 1.0
PRACTICAL_LENGTH_LIMIT_MM = 5.0
WEAK_FRACTION = 0.25


# -- scaling and indices -------------------------------------------------------------------
ZERO_COLUMN = 1e-10      # a column this much smaller than the largest has no effect (round-off)


def column_scales(phi: np.ndarray) -> np.ndarray:
    """Column norms of Φ. A column that is zero up to round-off (a parameter with no effect on
    the measured points, e.g. the angle of a joint whose axis passes through the target) gets
    an infinite scale, so that it is exactly zero in the scaled Φ instead of normalised noise."""
    norms = np.linalg.norm(phi, axis=0)
    if norms.size == 0:
        return norms
    return np.where(norms > ZERO_COLUMN * max(norms.max(), 1e-300), norms, np.inf)


def qr_r(A: np.ndarray, b: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray | None]:
    """R of A = Q·R (min(m, p) × p) and, with `b`, the first min(m, p) rows of Qᵀ·b — without
    forming Q: the R of the augmented [A | b] holds both (LAPACK through numpy)."""
    A = np.asarray(A, dtype=float)
    m, p = A.shape
    n = min(m, p)
    if b is None:
        return np.linalg.qr(A, mode="r")[:n], None
    R = np.linalg.qr(np.column_stack([A, np.asarray(b, dtype=float)]), mode="r")
    return R[:n, :p], R[:n, p]


def small_factor(A: np.ndarray) -> np.ndarray:
    """A matrix with at most as many rows as columns with the same singular values, right
    singular vectors and column dependencies as the tall A (its R). Rank tests and SVDs work
    on it (p × p instead of 3N × p)."""
    A = np.asarray(A, dtype=float)
    if A.shape[0] <= A.shape[1] or A.shape[1] == 0:
        return A
    return qr_r(A)[0]


def characteristic_scales(model: RobotModel, params: Sequence[Parameter]) -> np.ndarray:
    """Fixed column scales for comparing pose sets: 1/mm for lengths, 1/(reach·rad) for angles,
    so that every parameter is measured in 'mm at the tool'. Reach = sum of |a| + |d| + targets."""
    reach = sum(abs(j.a) + abs(j.d) for j in model.joints)
    reach += max((np.linalg.norm(t) for t in model.targets.values()), default=0.0)
    reach = max(reach, 1.0)
    return np.array([reach if p.angular else 1.0 for p in params])


@dataclass
class ObservabilityIndices:
    """Singular values, rank, condition number and O1…O5 of a (scaled) Φ (see module doc)."""

    singular_values: np.ndarray
    rank: int
    condition_number: float
    o1: float
    o2: float
    o3: float
    o4: float
    o5: float
    n_points: int
    n_parameters: int

    def as_dict(self) -> dict:
        return {"rank": self.rank, "n_parameters": self.n_parameters, "n_points": self.n_points,
                "condition_number": self.condition_number, "O1": self.o1, "O2": self.o2,
                "O3": self.o3, "O4": self.o4, "O5": self.o5}


def observability_indices(phi: np.ndarray, *, n_points: int | None = None,
                          scales: np.ndarray | None = None,
                          rank_tol: float = RANK_TOL) -> ObservabilityIndices:
    """Observability indices of Φ (3·n_points × L). Columns are divided by `scales` (default:
    the column norms of Φ). `n_points` defaults to rows / 3."""
    phi = np.asarray(phi, dtype=float)
    m_rows, L = phi.shape
    n_points = m_rows // 3 if n_points is None else int(n_points)
    D = column_scales(phi) if scales is None else np.asarray(scales, dtype=float)
    scaled = np.where(np.isfinite(D), phi / D, 0.0)
    s = np.linalg.svd(small_factor(scaled), compute_uv=False) if L else np.zeros(0)
    s = np.concatenate([s, np.zeros(max(0, L - len(s)))])   # fewer rows than columns
    rank = int(np.sum(s > rank_tol * s[0])) if L and s[0] > 0 else 0
    smax, smin = (float(s[0]), float(s[-1])) if L else (0.0, 0.0)
    full = L > 0 and smin > rank_tol * smax
    with np.errstate(divide="ignore"):
        o1 = float(np.exp(np.mean(np.log(s))) / math.sqrt(max(n_points, 1))) if full else 0.0
        o5 = float(1.0 / np.sum(1.0 / s ** 2)) if full else 0.0
    return ObservabilityIndices(
        singular_values=s, rank=rank, condition_number=smax / smin if full else math.inf,
        o1=o1, o2=smin / smax if smax > 0 else 0.0, o3=smin, o4=smin ** 2 / smax if smax > 0 else 0.0,
        o5=o5, n_points=n_points, n_parameters=L)


def _rank(phi_s: np.ndarray, tol: float) -> int:
    if phi_s.shape[1] == 0:
        return 0
    s = np.linalg.svd(phi_s, compute_uv=False)
    return int(np.sum(s > tol * s[0])) if s[0] > 0 else 0


def stacked_jacobian(model: RobotModel, Q, point_targets: Sequence[str], params: Sequence[Parameter],
                     weights: np.ndarray | None = None,
                     orientation_weights: np.ndarray | None = None) -> np.ndarray:
    """√W·Φ: the point rows (weights (N, 3), none: 1) and, when orientation parameters are among
    `params`, the orientation rows (core.kinematics.orientation) below them, weighted by
    √`orientation_weights` (N, 3), or by STRUCTURAL_ROW_SCALE when none are given."""
    phi = calibration_jacobian(model, Q, point_targets, params)
    if weights is not None:
        phi = np.sqrt(np.asarray(weights, dtype=float).reshape(-1))[:, None] * phi
    if not has_orientation_parameters(params):
        return phi
    sw = (np.full(phi.shape[0], STRUCTURAL_ROW_SCALE) if orientation_weights is None
          else np.sqrt(np.asarray(orientation_weights, dtype=float).reshape(-1)))
    return np.vstack([phi, sw[:, None] * orientation_jacobian(model, Q, point_targets, params)])


# -- structural identifiability ------------------------------------------------------------
@dataclass
class Exclusion:
    """A parameter that is not estimated: why, and which parameters absorb it."""

    name: str
    status: str                     # FIXED_BY_USER | HAYATI | NOT_IDENTIFIABLE
    partners: tuple[str, ...] = ()
    explanation: str = ""


@dataclass
class Identifiability:
    """The parameter vector split into estimated (`free`) and excluded parameters."""

    params: list[Parameter]
    free: list[Parameter]
    excluded: list[Exclusion]
    targets: list[str] = field(default_factory=list)

    @property
    def free_names(self) -> list[str]:
        return [p.name for p in self.free]

    def exclusion(self, name: str) -> Exclusion | None:
        return next((e for e in self.excluded if e.name == name), None)


def random_configurations(model: RobotModel, count: int, seed: int = 0) -> np.ndarray:
    """Configurations drawn uniformly within the joint limits (internal units; revolute
    ranges wider than ±180° sampled within ±180°)."""
    lo, hi = model.sampling_range()
    return np.random.default_rng(seed).uniform(lo, hi, size=(count, model.dof))


def _elimination_order(params: Sequence[Parameter]) -> list[int]:
    """Indices in the order parameters are preferably given up: joints from the last to the
    first (d, theta, a, alpha, beta within a joint), then targets, then the base; deflection terms
    (core.robot.compliance) before all of them: geometry comes first."""
    kind_rank = {"d": 0, "theta": 1, "a": 2, "alpha": 3, "beta": 4}
    group_rank = {"compliance": -1, "joint": 0, "target": 1, "orientation": 1, "base": 2}

    def key(k):
        p = params[k]
        return (group_rank[p.group], -p.joint, kind_rank.get(p.kind, 0), k)

    return sorted(range(len(params)), key=key)


def _partners(phi_s: np.ndarray, col: int, kept: list[int], params) -> tuple[str, ...]:
    """The kept parameters whose columns combine to the column `col` (largest first)."""
    if not kept:
        return ()
    coef, *_ = np.linalg.lstsq(phi_s[:, kept], phi_s[:, col], rcond=None)
    big = np.abs(coef)
    if big.max() <= 0:
        return ()
    order = np.argsort(-big)
    return tuple(params[kept[k]].name for k in order if big[k] > 0.05 * big.max())


def _names_text(names: Sequence[str], limit: int = 4) -> str:
    names = list(names)
    if len(names) > limit:
        return ", ".join(names[:limit]) + f" and {len(names) - limit} more"
    return ", ".join(names)


def explain_structural(prm: Parameter, partners: Sequence[str], params: Sequence[Parameter]) -> str:
    """Plain-language reason why `prm` cannot be estimated separately from `partners`."""
    by_name = {p.name: p for p in params}
    groups = {by_name[n].group for n in partners if n in by_name}
    kinds = {by_name[n].kind for n in partners if n in by_name}
    who = _names_text(partners)
    verb = "absorbs" if len(partners) == 1 else "absorb"
    tail = f" It is kept at its nominal value and {who} {verb} it."
    if not partners:
        if prm.group == "joint" and prm.kind in ("theta", "alpha", "beta"):
            return (f"{prm.name} does not move the measured points: they lie on the axis it rotates "
                    f"about. It is kept at its nominal value (the target offsets absorb any error).")
        return f"{prm.name} has no effect on the measured points. It is kept at its nominal value."
    if groups == {"base"}:
        if prm.group == "joint" and prm.joint == 0 and prm.kind == "theta" and kinds <= {"rx", "ry", "rz"}:
            return (f"{prm.name} cannot be told apart from {who}: both rotate the whole arm about the "
                    f"first joint axis." + tail)
        if prm.group == "joint" and prm.joint == 0 and prm.kind == "d" and kinds <= {"x", "y", "z"}:
            return (f"{prm.name} cannot be told apart from {who}: both shift the whole arm along the "
                    f"first joint axis." + tail)
        return f"{prm.name} cannot be told apart from {who}: both move the whole arm rigidly." + tail
    if "orientation" in groups and prm.group == "joint":
        return (f"{prm.name} cannot be told apart from the marker's orientation on the tool ({who}): it "
                f"turns the measured frame rigidly with the last link, as that orientation does. Fix the "
                f"marker's turn about the last axis when it is known (e.g. --fix marker.rz)." + tail)
    if groups == {"target"} or (groups <= {"target", "joint"} and "target" in groups
                                and prm.group == "joint"):
        return (f"{prm.name} cannot be told apart from the measured target offset ({who}): it moves "
                f"the measured points rigidly with the last link, as the target offset does (the "
                f"tool transform stays fixed)." + tail)
    if len(partners) == 1:
        return (f"{prm.name} cannot be told apart from {who}: with these targets their effects on the "
                f"measured points are proportional in every pose, so only their combination can be "
                f"estimated." + tail)
    return (f"{prm.name} cannot be told apart from a combination of {who}: their effects on the "
            f"measured points are the same in every pose, so only the combination can be estimated."
            + tail)


def explain_hayati(i: int, model: RobotModel, hayati: Sequence[int]) -> str:
    """Why Ji.d is kept fixed for a joint i (0-based) with Hayati's β."""
    nxt = i + 1
    while nxt in hayati and nxt < model.dof - 1:
        nxt += 1
    a, b = joint_label(i), joint_label(i + 1)
    absorber = f"{joint_label(nxt)}.d"
    return (f"The axes of {a} and {b} are parallel: {a}.d and {b}.d slide the rest of the arm along "
            f"the same direction, so only their sum is defined (and the DH common normal, hence "
            f"{a}.d, jumps for the smallest misalignment). Following Hayati, {a}.beta takes up the "
            f"axes' misalignment and {a}.d is kept at its nominal value; {absorber} absorbs it.")


def analyse(model: RobotModel, targets: Sequence[str], *, fixed: Iterable[str] = (),
            n_poses: int = STRUCTURAL_POSES, seed: int = 0, params: Sequence[Parameter] | None = None,
            rank_tol: float = RANK_TOL) -> Identifiability:
    """Split g into estimated and excluded parameters for `model` with the measured `targets`
    (fixed by the user, Hayati's d, structurally not identifiable), with explanations."""
    params = list(params) if params is not None else all_parameters(model, targets)
    fixed_names = set(resolve_names(fixed, params, model))
    hayati = hayati_joints(model)
    excluded: list[Exclusion] = []
    candidates = []
    for k, p in enumerate(params):
        if p.name in fixed_names:
            excluded.append(Exclusion(p.name, FIXED_BY_USER, (),
                                      f"{p.name} was fixed by the user: it is kept at its nominal value."))
        elif p.group == "joint" and p.kind == "d" and p.joint in hayati:
            excluded.append(Exclusion(p.name, HAYATI, (f"{joint_label(p.joint + 1)}.d",),
                                      explain_hayati(p.joint, model, hayati)))
        else:
            candidates.append(k)
    if not targets:
        raise RoboCalError("no measured targets", hint="Measure at least one target point.")
    Q, names = expand_poses(random_configurations(model, max(n_poses, len(params)), seed), list(targets))
    phi = stacked_jacobian(model, Q, names, params)
    phi_s = small_factor(phi / column_scales(phi))
    kept = list(candidates)
    r = _rank(phi_s[:, kept], rank_tol)
    dropped = []
    for k in _elimination_order(params):
        if len(kept) <= r:
            break
        if k not in kept:
            continue
        trial = [c for c in kept if c != k]
        if _rank(phi_s[:, trial], rank_tol) == r:
            kept = trial
            dropped.append(k)
    for k in dropped:
        partners = _partners(phi_s, k, kept, params)
        excluded.append(Exclusion(params[k].name, NOT_IDENTIFIABLE, partners,
                                  explain_structural(params[k], partners, params)))
    order = {p.name: i for i, p in enumerate(params)}
    excluded.sort(key=lambda e: order[e.name])
    kept.sort()
    return Identifiability(params=params, free=[params[k] for k in kept], excluded=excluded,
                           targets=list(targets))


def practical_identifiability(ident: Identifiability, model: RobotModel, Q: np.ndarray,
                              point_targets: Sequence[str], weights: np.ndarray, sigma_hat: float, *,
                              angle_limit_deg: float = PRACTICAL_ANGLE_LIMIT_DEG,
                              length_limit_mm: float = PRACTICAL_LENGTH_LIMIT_MM,
                              orientation_weights: np.ndarray | None = None) -> Identifiability:
    """Remove from `ident.free` the joint and target parameters whose expected standard deviation
    σ̂·sqrt(diag((ΦᵀWΦ)⁻¹)) on these measurements exceeds the limits, one at a time in the
    elimination order (recomputing after each removal). `weights` are per coordinate (N, 3);
    `orientation_weights` (N, 3, rad⁻²) add the measured orientations' rows."""
    free = list(ident.free)
    excluded = list(ident.excluded)
    phi_all = stacked_jacobian(model, Q, point_targets, free, weights, orientation_weights)
    D_all = column_scales(phi_all)
    R_all = small_factor(phi_all)
    limit = {True: math.radians(angle_limit_deg), False: float(length_limit_mm)}
    keep = list(range(len(free)))
    order = _elimination_order(free)
    while True:
        D = D_all[keep]
        A = np.where(np.isfinite(D), R_all[:, keep] / D, 0.0)
        _, s, Vt = np.linalg.svd(A, full_matrices=False)
        with np.errstate(divide="ignore"):
            inv = np.where(s > 1e-14 * max(s[0], 1e-300), 1.0 / s ** 2, np.inf)
        var = (Vt.T ** 2) @ inv
        with np.errstate(invalid="ignore"):
            std = sigma_hat * np.sqrt(var) / D
        std = np.where(np.isfinite(D), std, np.inf)
        # the base is always estimated; deflection terms carry their own ridge (core.identification.prior)
        ratio = {keep[k]: (std[k] / limit[free[keep[k]].angular]
                           if free[keep[k]].group not in ("base", "compliance") else 0.0)
                 for k in range(len(keep))}
        if not any(not r <= 1.0 for r in ratio.values()):
            break
        # drop the first *weak* parameter (std above a quarter of its limit) in the elimination
        # order: of a nearly dependent pair both are weak, and which one crosses the limit
        # first depends on the noise; the order does not
        weak = {k for k, r in ratio.items() if not r <= WEAK_FRACTION}
        k = next(k for k in order if k in weak)
        pos = keep.index(k)
        shown = (f"± {math.degrees(std[pos]):.2g}°" if free[k].angular else f"± {std[pos]:.2g} mm") \
            if math.isfinite(std[pos]) else "no constraint at all"
        keep.remove(k)
        A_keep = np.where(np.isfinite(D_all[keep]), R_all[:, keep] / D_all[keep], 0.0)
        col = R_all[:, [k]] / D_all[k] if math.isfinite(D_all[k]) else np.zeros((len(R_all), 1))
        partners = _partners(np.hstack([A_keep, col]), len(keep), list(range(len(keep))),
                             [free[j] for j in keep])
        who = _names_text(partners)
        reason = (f"the measurements barely determine {free[k].name} (it would come out {shown}"
                  + (f"; its effect is almost that of {who}" if partners else "") + ")")
        if free[k].group == "joint" and free[k].joint >= model.dof - 2 and any(
                n.split(".")[0] in ident.targets for n in partners):
            reason += "; the measured targets lie close to the last joint axes"
        excluded.append(Exclusion(free[k].name, NOT_DETERMINED, partners,
                                  reason[0].upper() + reason[1:] + ". It is kept at its nominal value"
                                  + (f" and {who} absorb{'s' if len(partners) == 1 else ''} it." if partners else ".")))
    order_names = {p.name: i for i, p in enumerate(ident.params)}
    excluded.sort(key=lambda e: order_names[e.name])
    return Identifiability(params=ident.params, free=[free[k] for k in sorted(keep)], excluded=excluded,
                           targets=ident.targets)


# -- the data ------------------------------------------------------------------------------
def recommended_poses(n_params: int, targets_per_pose: float = 1.0) -> int:
    """Poses to take for `n_params` parameters: about twice as many equations as unknowns."""
    return max(10, int(math.ceil(2.0 * n_params / (3.0 * max(targets_per_pose, 1.0)))))


def joint_ranges(model: RobotModel, Q: np.ndarray) -> np.ndarray:
    """Range of each joint over the configurations, in file units (deg / mm)."""
    Qf = model.q_to_file(Q)
    return Qf.max(axis=0) - Qf.min(axis=0) if len(Qf) else np.zeros(model.dof)


def _move_hint(model: RobotModel, Q: np.ndarray, involved: Iterable[int] = ()) -> str:
    ranges = joint_ranges(model, Q)
    small = [i for i in range(model.dof)
             if ranges[i] < (10.0 if model.joints[i].revolute else 10.0)]
    parts = []
    if small:
        desc = ", ".join(f"{joint_label(i)} {ranges[i]:.1f} {'deg' if model.joints[i].revolute else 'mm'}"
                         for i in small)
        parts.append(f"move every joint over a wide range (these barely move: {desc})")
    else:
        involved = sorted(set(involved))
        if involved:
            parts.append("move " + ", ".join(joint_label(i) for i in involved)
                         + " through more varied angles, in combination with the other joints")
        else:
            parts.append("spread the poses over the whole workspace")
    return "; ".join(parts)


def check_data(model: RobotModel, Q: np.ndarray, point_targets: Sequence[str], ident: Identifiability,
               *, source=None, rank_tol: float = DATA_RANK_TOL,
               orientation_weights: np.ndarray | None = None) -> ObservabilityIndices:
    """Check that the measured points determine the free parameters; return the indices of
    their Φ. Raises RoboCalError saying what to measure when they do not. `orientation_weights`
    (N, 3; zero where a point has none) add the measured orientations' rows."""
    n_points = len(point_targets)
    n_poses = len({tuple(q) for q in np.round(np.asarray(Q), 9)})
    p = len(ident.free)
    per_pose = n_points / max(n_poses, 1)
    rec = recommended_poses(p, per_pose)
    if 3 * n_points <= p:
        raise RoboCalError(
            f"too few measurements: {n_points} points give {3 * n_points} equations for {p} parameters",
            source=source,
            hint=f"Measure at least {rec} poses (now {n_poses}) and {_move_hint(model, Q)}.")
    phi = stacked_jacobian(model, Q, point_targets, ident.free, orientation_weights=orientation_weights)
    D = column_scales(phi)
    _, s, Vt = np.linalg.svd(small_factor(np.where(np.isfinite(D), phi / D, 0.0)), full_matrices=False)
    rank = int(np.sum(s > rank_tol * s[0])) if s[0] > 0 else 0
    if rank < p:
        null = Vt[rank:]
        weight = np.linalg.norm(null, axis=0)
        order = np.argsort(-weight)
        names = [ident.free[k].name for k in order if weight[k] > 0.1][:6]
        joints = [ident.free[k].joint for k in order if weight[k] > 0.1 and ident.free[k].joint >= 0]
        move = _move_hint(model, Q, joints)
        hint = (f"Measure more poses (at least {rec}, now {n_poses}) and {move}." if n_poses < rec else
                f"{move[0].upper()}{move[1:]}; more poses like these will not help.")
        raise RoboCalError(
            f"the measured poses cannot determine {_names_text(names, 6)} (rank {rank} of {p} "
            f"parameters with {n_poses} poses)", source=source, hint=hint)
    return observability_indices(phi, n_points=n_points, scales=D)


def observation_matrix(model: RobotModel, Q_poses, targets: Sequence[str] | None = None, *,
                       fixed: Iterable[str] = (), identifiable_only: bool = True,
                       ident: Identifiability | None = None) -> tuple[np.ndarray, list[str]]:
    """Φ for a robot, configurations Q_poses (P, n; internal units) and targets (default: all of
    the robot's targets), with no measurements: every pose sees every target. Returns (Φ, names);
    with `identifiable_only`, only the parameters `analyse` keeps. For pose selection."""
    targets = list(model.targets) if targets is None else list(targets)
    Q, names = expand_poses(Q_poses, targets)
    if identifiable_only:
        ident = ident or analyse(model, targets, fixed=fixed)
        params = ident.free
    else:
        params = all_parameters(model, targets)
    return calibration_jacobian(model, Q, names, params), [p.name for p in params]
