"""Pose selection by observability (the chapter's section 2.2, Sun & Hollerbach).

Which N of M candidate configurations (core.poses.candidates) make the geometric parameters
best observable? The measure is an observability index of Φ, the calibration Jacobian stacked
over the poses (core.kinematics.jacobian, eq. 5–7), restricted to the identifiable
parameters (core.kinematics.identifiability.analyse) and column-scaled with *fixed* characteristic
scales (`characteristic_scales`: 1/mm for lengths, 1/(reach·rad) for angles), so that every
candidate set is measured with the same yardstick. With σ_1 ≥ … ≥ σ_L the singular values of
the scaled Φ (see core.kinematics.identifiability for the definitions):

    cond = σ_1/σ_L (smaller is better)     O1 = (σ_1⋯σ_L)^(1/L)/√m (D-optimal)
    O3 = σ_L (E-optimal)                   O4 = σ_L²/σ_1 (noise amplification)
    O5 = 1/Σ σ_i⁻² (A-optimal)

Selection works on the small information matrix M = Φ_sᵀΦ_s = Σ_poses A_iᵀA_i (L × L, L ≈ 25–35),
where A_i are the 3·T scaled rows of pose i (T targets). Adding or removing a pose is a
rank-3T update of M, evaluated for all candidates at once:

* O1: log det(M ± AᵀA) = log det M + log det(I ± A M⁻¹ Aᵀ)  (matrix determinant lemma);
* O5: tr((M ± AᵀA)⁻¹) = tr M⁻¹ ∓ tr(C ᵀ(I ± C Aᵀ)⁻¹ C), C = A M⁻¹  (Sherman–Morrison–Woodbury);
* cond, O3, O4: the eigenvalues of the updated L × L matrices (numpy's batched eigvalsh), with
  exact branch and bound: a unit vector v gives λ_min(M + AᵀA) ≤ vᵀMv + |Av|² and
  λ_max(M + AᵀA) ≥ vᵀMv + |Av|², so with the eigenvectors of M every candidate gets an upper
  bound of its score; candidates are evaluated best bound first and the search stops when no
  bound can beat the best exact score found (the same choice as evaluating every candidate).

Algorithm (seeded, deterministic):
1. greedy build-up: D-optimal (log det(M + εI)) until M has full rank, then the chosen index,
   one pose at a time up to N (a pose is used at most once);
2. exchange (Mitchell's DETMAX): excursions that add k poses then remove k (or remove then add),
   k = 1, 2, 3, each step by the chosen index; an excursion is kept when the index improves,
   and the search stops when no excursion up to depth 3 improves it;
3. the curve of the index versus N: the selected set shrunk by backward elimination down to
   the smallest N that identifies every parameter, and grown greedily beyond N (nested sets
   through the selection); beside it the median over K random selections of each size;
4. ordering for short travel (core.poses.ordering);
5. every figure reported for the final set is recomputed from scratch (SVD of its Φ).

The smallest usable N: 3·N·T equations must exceed L parameters (N ≥ ⌊L/3T⌋ + 1), as the
identification demands; about twice as many equations is the recommended minimum.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Iterable, Sequence

import numpy as np

from core.errors import RoboCalError, UsageError
from core.kinematics.identifiability import (RANK_TOL, ObservabilityIndices, analyse, characteristic_scales,
                                             observation_matrix, observability_indices, recommended_poses)
from core.robot.model import RobotModel
from core.poses.candidates import (DEFAULT_MARGIN_DEG, CandidateSet, VisibilityOptions, generate_candidates,
                                  no_candidate_error)
from core.poses.file import write_poses
from core.poses.ordering import home_configuration, order_poses, path_length
from core.stereo.rig import StereoRig
from core.task import Monitor

INDEXES = ("cond", "O1", "O3", "O4", "O5")
#: one line per index, for choosers and legends (σ_i the singular values of the scaled Φ)
INDEX_DESCRIPTIONS = {
    "cond": "Condition number κ (smaller is better)",
    "O1": "O1: D-optimal, grows as the error ellipsoid's volume shrinks",
    "O3": "O3: E-optimal, smallest singular value",
    "O4": "O4: noise amplification index",
    "O5": "O5: A-optimal, reciprocal of the total variance 1/Σσ⁻²",
}
#: keys of ObservabilityIndices.as_dict() for each index
INDEX_KEYS = {"cond": "condition_number", "O1": "O1", "O3": "O3", "O4": "O4", "O5": "O5"}
DEFAULT_CANDIDATES = 2000
DEFAULT_RANDOM_TRIALS = 100
MAX_DEPTH = 3
MAX_EXCHANGES = 500
_IMPROVE = 1e-9          # relative improvement of the log-score an exchange must bring
_CHUNK = 64              # candidates per batched eigvalsh in the branch and bound
_RANK = 1e-12            # λ_min / λ_max below which an information matrix counts as singular


def lower_is_better(index: str) -> bool:
    return index == "cond"


def check_index(index: str) -> str:
    """The canonical name of an index ('cond', 'O1', …; case-insensitive, 'kappa' accepted)."""
    key = str(index).strip()
    canon = {"cond": "cond", "kappa": "cond", "condition": "cond", "o1": "O1", "o3": "O3", "o4": "O4",
             "o5": "O5"}.get(key.lower())
    if canon is None:
        raise UsageError(f"unknown observability index {index!r}", hint=f"Use one of {', '.join(INDEXES)}.")
    return canon


# -- indices from eigenvalues of the information matrix -----------------------------------
def indices_from_eigenvalues(lam: np.ndarray, n_points: int) -> dict[str, np.ndarray]:
    """cond, O1, O3, O4, O5 (arrays over the leading axes) from the eigenvalues (..., L) of
    ΦᵀΦ, with the conventions of core.kinematics.identifiability.observability_indices (σ = √λ)."""
    lam = np.asarray(lam, dtype=float)
    s = np.sqrt(np.clip(lam, 0.0, None))
    smax, smin = s.max(axis=-1), s.min(axis=-1)
    full = smin > RANK_TOL * smax
    with np.errstate(divide="ignore", invalid="ignore"):
        logs = np.log(np.where(full[..., None], s, 1.0))
        o1 = np.where(full, np.exp(logs.mean(axis=-1)) / math.sqrt(max(n_points, 1)), 0.0)
        o5 = np.where(full, 1.0 / np.sum(1.0 / np.where(full[..., None], s, 1.0) ** 2, axis=-1), 0.0)
        cond = np.where(full, smax / np.where(full, smin, 1.0), np.inf)
        o4 = np.where(smax > 0, smin ** 2 / np.where(smax > 0, smax, 1.0), 0.0)
    return {"cond": cond, "O1": o1, "O3": smin, "O4": o4, "O5": o5}


def _score(index: str, lam: np.ndarray) -> np.ndarray:
    """Log-score to maximise for eigenvalues (..., L) of M; −inf for a singular M."""
    lam = np.asarray(lam, dtype=float)
    lmax, lmin = lam.max(axis=-1), lam.min(axis=-1)
    ok = lmin > _RANK * np.maximum(lmax, 1e-300)
    with np.errstate(divide="ignore", invalid="ignore"):
        L = np.log(np.where(ok[..., None], lam, 1.0))
        if index == "cond":
            s = np.log(np.where(ok, lmin, 1.0)) - np.log(np.where(ok, lmax, 1.0))
        elif index == "O1":
            s = L.mean(axis=-1)
        elif index == "O3":
            s = np.log(np.where(ok, lmin, 1.0))
        elif index == "O4":
            s = np.log(np.where(ok, lmin, 1.0)) - 0.5 * np.log(np.where(ok, lmax, 1.0))
        else:  # O5
            s = -np.log(np.sum(1.0 / np.where(ok[..., None], lam, 1.0), axis=-1))
    return np.where(ok, s, -np.inf)


# -- the selector ---------------------------------------------------------------------------
class _Selector:
    """Greedy and exchange steps on the per-pose blocks A (M, r, L) of the scaled Φ."""

    def __init__(self, A: np.ndarray, index: str, monitor: Monitor | None = None):
        self.A = np.ascontiguousarray(A)
        self.M, self.r, self.L = A.shape
        self.G = np.einsum("nki,nkj->nij", self.A, self.A)                 # (M, L, L)
        self.index = index
        self.eps = 1e-8 * float(np.mean(np.trace(self.G, axis1=1, axis2=2))) / max(self.L, 1)
        self.monitor = monitor or Monitor()
        self.evaluations = 0       # candidate evaluations (for the curious)

    def info(self, chosen: Sequence[int]) -> np.ndarray:
        idx = np.asarray(list(chosen), dtype=int)
        return self.G[idx].sum(axis=0) if len(idx) else np.zeros((self.L, self.L))

    def value(self, chosen: Sequence[int], index: str | None = None) -> float:
        return float(_score(index or self.index, np.linalg.eigvalsh(self.info(chosen))))

    def full_rank(self, info: np.ndarray) -> bool:
        lam = np.linalg.eigvalsh(info)
        return bool(lam[0] > _RANK * max(lam[-1], 1e-300))

    # -- adding ---------------------------------------------------------------------------
    def _closed_form_add(self, index: str, info: np.ndarray, cand: np.ndarray) -> np.ndarray:
        P = np.linalg.inv(info + self.eps * np.eye(self.L))
        A = self.A[cand]
        C = A @ P                                                          # (k, r, L)
        K = np.eye(self.r) + np.einsum("nki,nji->nkj", C, A)               # I + A P Aᵀ
        if index == "O1":
            sign, logdet = np.linalg.slogdet(K)
            return np.where(sign > 0, logdet, -np.inf)
        # O5: tr((M + AᵀA)⁻¹) = tr P − tr(Cᵀ K⁻¹ C)
        CCt = np.einsum("nki,nji->nkj", C, C)
        return np.einsum("nkj,njk->n", np.linalg.inv(K), CCt)

    def _eig_add(self, index: str, info: np.ndarray, cand: np.ndarray,
                 threshold: float = -np.inf) -> tuple[int, float]:
        """Best candidate by an eigenvalue index (exact branch and bound, see module doc), and its
        score; (−1, −inf) when none scores above `threshold`."""
        lam, V = np.linalg.eigh(info)
        A = self.A[cand]
        AV2 = (A @ V) ** 2
        rq = lam[None, :] + AV2.sum(axis=1)                                 # Rayleigh quotients (k, L)
        ub_min = rq.min(axis=1)
        lb_max = rq.max(axis=1)
        with np.errstate(divide="ignore"):
            if index == "cond":
                bound = np.log(ub_min) - np.log(lb_max)
            elif index == "O3":
                bound = np.log(ub_min)
            elif index == "O4":
                bound = np.log(ub_min) - 0.5 * np.log(lb_max)
            else:
                bound = np.full(len(cand), np.inf)
        order = np.lexsort((np.arange(len(cand)), -bound))   # best bound first, then lowest number
        best, best_k = -np.inf, -1
        for start in range(0, len(order), _CHUNK):
            ks = order[start:start + _CHUNK]
            if bound[ks[0]] < max(best, threshold) and (best_k >= 0 or threshold > -np.inf):
                break
            sc = _score(index, np.linalg.eigvalsh(info[None] + self.G[cand[ks]]))
            self.evaluations += len(ks)
            top = np.flatnonzero(sc == sc.max())
            k = int(ks[top[np.argmin(cand[ks[top]])]])
            s = float(sc.max())
            if s > best or (s == best and best_k >= 0 and cand[k] < cand[best_k]):
                best, best_k = s, k
        if best_k < 0 or not np.isfinite(best) or best <= threshold:
            return -1, -np.inf
        return int(cand[best_k]), best

    def best_swap(self, chosen: list[int]) -> list[int] | None:
        """Fedorov's exchange: the best single swap (a selected pose for a candidate) over every
        pair, or None when no swap improves the index."""
        best = self.value(chosen)
        tol = _IMPROVE * max(abs(best), 1.0)
        used = np.zeros(self.M, dtype=bool)
        used[chosen] = True
        cand = np.flatnonzero(~used)
        found = None
        for pos in range(len(chosen)):
            rest = chosen[:pos] + chosen[pos + 1:]
            info = self.info(rest)
            if self.index in ("O1", "O5") or not self.full_rank(info):
                crit = self.index if self.full_rank(info) else "O1"
                if crit != self.index:
                    continue
                sc = self._closed_form_add(crit, info, cand)
                self.evaluations += len(cand)
                i = int(cand[int(np.argmax(sc))])
                v = self.value(rest + [i])
            else:
                i, v = self._eig_add(self.index, info, cand, threshold=best + tol)
            if i >= 0 and v > best + tol:
                best, found = v, (pos, i)
        if found is None:
            return None
        pos, i = found
        return chosen[:pos] + [i] + chosen[pos + 1:]

    def best_add(self, chosen: Sequence[int], index: str | None = None) -> int:
        """The candidate whose addition gives the best index (O1 while M is singular)."""
        used = np.zeros(self.M, dtype=bool)
        used[list(chosen)] = True
        cand = np.flatnonzero(~used)
        if len(cand) == 0:
            raise RoboCalError("no candidate left to add")
        info = self.info(chosen)
        index = index or self.index
        if index in ("O1", "O5") or not self.full_rank(info):
            crit = index if (index in ("O1", "O5") and self.full_rank(info)) else "O1"
            sc = self._closed_form_add(crit, info, cand)
            self.evaluations += len(cand)
            return int(cand[int(np.argmax(sc))])
        i, s = self._eig_add(index, info, cand)
        if i < 0:   # every addition leaves M singular (cannot happen with full-rank M): D-optimal
            sc = self._closed_form_add("O1", info, cand)
            return int(cand[int(np.argmax(sc))])
        return i

    # -- removing -------------------------------------------------------------------------
    def best_remove(self, chosen: Sequence[int], index: str | None = None) -> int:
        """The pose of `chosen` whose removal keeps the best index (position in `chosen`)."""
        chosen = list(chosen)
        idx = np.array(chosen, dtype=int)
        info = self.info(idx)
        index = index or self.index
        if index in ("O1", "O5"):
            P = np.linalg.inv(info + self.eps * np.eye(self.L))
            A = self.A[idx]
            C = A @ P
            K = np.eye(self.r) - np.einsum("nki,nji->nkj", C, A)           # I − A P Aᵀ
            sign, logdet = np.linalg.slogdet(K)
            if index == "O1":
                sc = np.where(sign > 0, logdet, -np.inf)
            else:
                with np.errstate(all="ignore"):
                    CCt = np.einsum("nki,nji->nkj", C, C)
                    grow = np.einsum("nkj,njk->n", np.linalg.inv(np.where(sign[:, None, None] > 0, K,
                                                                          np.eye(self.r))), CCt)
                sc = np.where(sign > 0, -grow, -np.inf)
        else:
            sc = _score(index, np.linalg.eigvalsh(info[None] - self.G[idx]))
        if not np.any(np.isfinite(sc)) and index != "O1":
            return self.best_remove(chosen, "O1")
        return int(np.argmax(sc))

    # -- the algorithm --------------------------------------------------------------------
    def greedy(self, n: int, start: Sequence[int] = ()) -> list[int]:
        chosen = list(start)
        while len(chosen) < n:
            self.monitor.step(len(chosen) / max(n, 1), f"greedy build-up: {len(chosen)} of {n} poses")
            chosen.append(self.best_add(chosen))
        return chosen

    def _excursion(self, chosen: list[int], depth: int, up: bool) -> list[int] | None:
        trial = list(chosen)
        for step in ("add", "remove") if up else ("remove", "add"):
            for _ in range(depth):
                if step == "add":
                    trial.append(self.best_add(trial))
                else:
                    trial.pop(self.best_remove(trial))
        return None if set(trial) == set(chosen) else trial

    def exchange(self, chosen: list[int], max_depth: int = MAX_DEPTH,
                 max_exchanges: int = MAX_EXCHANGES, swaps: bool = True) -> tuple[list[int], int]:
        best = self.value(chosen)
        accepted = 0
        while accepted < max_exchanges:
            self.monitor.step(min(accepted / 50.0, 0.95), f"exchange: {accepted} improvements")
            improved = False
            for depth in range(1, max_depth + 1):
                for up in (True, False):
                    if len(chosen) - depth < 1:
                        continue
                    trial = self._excursion(chosen, depth, up)
                    if trial is None:
                        continue
                    v = self.value(trial)
                    if v > best + _IMPROVE * max(abs(best), 1.0):
                        chosen, best, improved = trial, v, True
                        break
                if improved:
                    break
            if not improved and swaps:
                trial = self.best_swap(chosen)
                if trial is not None:
                    chosen, best, improved = trial, self.value(trial), True
            if not improved:
                break
            accepted += 1
        return chosen, accepted

    def shrink(self, chosen: Sequence[int], n_min: int) -> list[list[int]]:
        """Nested subsets of `chosen` by backward elimination, down to n_min poses."""
        out = []
        cur = list(chosen)
        while len(cur) > n_min:
            cur = list(cur)
            cur.pop(self.best_remove(cur))
            out.append(cur)
        return out


# -- results --------------------------------------------------------------------------------
@dataclass
class RandomComparison:
    """The indices of `trials` random selections of the same size from the same candidates."""

    trials: int
    median: dict[str, float]
    values: dict[str, np.ndarray]        # (trials,) per index


@dataclass
class IndexCurve:
    """Each index versus the number of poses: the nested sets through the selection and the
    median (and quartiles) over random selections of each size."""

    n: np.ndarray
    selected: dict[str, np.ndarray]
    random_median: dict[str, np.ndarray]
    random_q25: dict[str, np.ndarray]
    random_q75: dict[str, np.ndarray]
    count: int                            # the N that was asked for


@dataclass
class PoseSelectionResult:
    """What pose selection produces — what the page draws and the CLI prints.

    `Q`/`q_file`: the selected poses in visiting order (internal units / deg-mm);
    `candidate_index`: their rows in `candidates.Q`; `indices`: the observability indices of
    their scaled Φ (SVD from scratch); `random`: the same for random selections of the same
    size; `curve`: index versus N; travel along the poses from the home configuration before
    (selection order) and after ordering, in `travel_unit`."""

    robot: RobotModel
    index: str
    count: int
    Q: np.ndarray
    q_file: np.ndarray
    candidate_index: np.ndarray
    candidates: CandidateSet
    targets: list[str]
    parameters: list[str]
    scales: np.ndarray
    indices: ObservabilityIndices
    random: RandomComparison
    curve: IndexCurve
    travel_before: float
    travel_after: float
    travel_metric: str
    home_file: np.ndarray
    n_min: int
    recommended: int
    exchanges: int
    seed: int
    seconds: float
    marker: np.ndarray                    # (N, 3) target positions, world frame (mm)
    depth: np.ndarray | None              # (N,) marker depth in the left camera frame (mm), with a rig
    warnings: list[str] = field(default_factory=list)
    path: Path | None = None              # poses.csv, once written

    def __len__(self) -> int:
        return len(self.Q)

    def value(self, index: str | None = None) -> float:
        return float(self.indices.as_dict()[INDEX_KEYS[index or self.index]])

    def random_median(self, index: str | None = None) -> float:
        return float(self.random.median[index or self.index])

    def ratio(self, index: str | None = None) -> float:
        """Selected / random median of the index (< 1 is better for cond, > 1 for the others)."""
        med = self.random_median(index)
        return self.value(index) / med if med not in (0.0, math.inf) else math.nan

    def as_dict(self) -> dict:
        """The CLI's --json object (finite numbers; infinities as null)."""
        sel = {k: _float_or_none(v) for k, v in self.indices.as_dict().items()}
        return {
            "count": self.count, "index": self.index, "seed": self.seed,
            "indices": sel,
            "random_median": {INDEX_KEYS[k]: _float_or_none(v) for k, v in self.random.median.items()},
            "random_trials": self.random.trials,
            "ratio_to_random": _float_or_none(self.ratio()),
            "parameters": list(self.parameters), "n_parameters": len(self.parameters),
            "targets": list(self.targets), "min_poses": self.n_min, "recommended_poses": self.recommended,
            "candidates": len(self.candidates), "candidates_wanted": self.candidates.wanted,
            "drawn": self.candidates.drawn, "rejected": dict(self.candidates.rejected),
            "constraints": list(self.candidates.constraints),
            "travel_before": self.travel_before, "travel_after": self.travel_after,
            "travel_unit": travel_unit(self.travel_metric), "travel_metric": self.travel_metric,
            "exchanges": self.exchanges, "seconds": self.seconds,
            "curve": {"n": self.curve.n.tolist(),
                      "selected": [_float_or_none(v) for v in self.curve.selected[self.index]],
                      "random_median": [_float_or_none(v) for v in self.curve.random_median[self.index]]},
            "poses": [[float(v) for v in row] for row in self.q_file],
            "depth_mm": None if self.depth is None else [float(v) for v in self.depth],
            "warnings": list(self.warnings),
            "out": str(self.path) if self.path else None,
        }


def travel_unit(metric: str) -> str:
    return "deg (largest joint move, summed)" if metric == "max" else "deg (joint-space distance, summed)"


def _float_or_none(v):
    """v as a float, or None when it is NaN or infinite (strict JSON)."""
    v = float(v)
    return v if math.isfinite(v) else None


# -- the step -------------------------------------------------------------------------------
def scaled_blocks(robot: RobotModel, Q: np.ndarray, targets: Sequence[str], *, fixed: Iterable[str] = ()):
    """Per-pose blocks of the column-scaled Φ for configurations Q (M, n): returns
    (A (M, 3T, L), parameter names, scales (L,), Identifiability)."""
    ident = analyse(robot, list(targets), fixed=fixed)
    scales = characteristic_scales(robot, ident.free)
    if len(Q) == 0:
        return np.zeros((0, 3 * len(targets), len(ident.free))), ident.free_names, scales, ident
    phi, names = observation_matrix(robot, Q, list(targets), ident=ident)
    A = (phi / scales).reshape(len(Q), 3 * len(targets), len(names))
    return A, names, scales, ident


def minimum_poses(robot: RobotModel, targets: Sequence[str] = ("marker",), *, fixed: Iterable[str] = ()) -> int:
    """The fewest poses identification can use for `robot` measured at `targets`: the 3·N·T
    equations of N poses must exceed its L identifiable parameters (`fixed` ones left out).
    Targets the robot lacks are dropped (its first target when none is left); 0 for a robot
    without targets."""
    names = [t for t in targets if t in robot.targets] or list(robot.targets)[:1]
    if not names:
        return 0
    return len(analyse(robot, names, fixed=fixed).free) // (3 * len(names)) + 1


def random_sets(rng: np.random.Generator, M: int, n: int, trials: int) -> np.ndarray:
    """`trials` random subsets of n of range(M) (rows of indices), without repetition."""
    keys = rng.random((trials, M))
    return np.argpartition(keys, n - 1, axis=1)[:, :n] if n < M else np.tile(np.arange(M), (trials, 1))


def random_indices(G: np.ndarray, n: int, trials: int, rng: np.random.Generator,
                   targets_per_pose: int = 1) -> dict[str, np.ndarray]:
    """The indices of `trials` random selections of n poses, from per-pose information blocks
    G (M, L, L) of the scaled Φ."""
    idx = random_sets(rng, len(G), n, trials)
    lam = np.linalg.eigvalsh(G[idx].sum(axis=1))
    return indices_from_eigenvalues(lam, n * targets_per_pose)


def select_poses(robot: RobotModel, count: int, *, candidates: int = DEFAULT_CANDIDATES, index: str = "cond",
                 seed: int = 0, margin=DEFAULT_MARGIN_DEG, rig: StereoRig | None = None, plate_size=None,
                 target: str = "marker", visibility: VisibilityOptions | None = None,
                 floor: float | None = None, targets: Sequence[str] | None = None, fixed: Iterable[str] = (),
                 random_trials: int = DEFAULT_RANDOM_TRIALS, curve_max: int | None = None,
                 metric: str = "max", candidate_set: CandidateSet | None = None,
                 max_depth: int = MAX_DEPTH, progress=None, cancelled=None) -> PoseSelectionResult:
    """Choose `count` poses from `candidates` feasible candidates (core.poses.candidates) that
    optimise `index` (cond, O1, O3, O4, O5), order them for short travel, and compare them with
    random selections. With a `rig` (and the marker `plate_size`), the robot's world frame must
    be the left camera frame. Raises RoboCalError with what to change for bad input."""
    t0 = time.perf_counter()
    index = check_index(index)
    monitor = Monitor(progress, cancelled)
    if count < 1:
        raise UsageError(f"the number of poses must be at least 1, got {count}")
    if random_trials < 1:
        raise UsageError(f"the number of random selections must be at least 1, got {random_trials}")
    targets = list(targets) if targets is not None else ([target] if target in robot.targets else list(robot.targets))
    if not targets:
        raise RoboCalError(f"the robot '{robot.name}' has no target point to measure",
                           hint="Add a target (e.g. \"marker\": [0, 0, 25]) to the robot model.")
    ident = analyse(robot, targets, fixed=fixed)
    L = len(ident.free)
    n_min = minimum_poses(robot, targets, fixed=fixed)
    recommended = max(n_min, recommended_poses(L, len(targets)))
    if count < n_min:
        raise UsageError(
            f"{count} poses are too few: {L} identifiable parameters need more than {L} equations, "
            f"i.e. at least {n_min} poses ({3 * len(targets)} equations per pose)",
            hint=f"Choose at least {n_min} poses (about {recommended} or more is recommended).")

    # candidates
    if candidate_set is None:
        candidate_set = generate_candidates(robot, candidates, seed=seed, margin=margin, rig=rig,
                                            plate_size=plate_size, target=target, visibility=visibility,
                                            floor=floor, progress=monitor.sub(0.0, 0.25),
                                            cancelled=cancelled)
    cands = candidate_set
    warnings = []
    if len(cands) == 0:
        raise no_candidate_error(cands, robot, with_rig=rig is not None)
    if len(cands) < count:
        raise RoboCalError(
            f"only {len(cands)} feasible candidate poses for {count} poses ({cands.drawn} drawn; "
            + ", ".join(f"{k}: {v}" for k, v in cands.rejected.items() if v) + ")",
            hint="Ask for more candidates, smaller joint margins or fewer poses.")
    if len(cands) < cands.wanted:
        warnings.append(f"only {len(cands)} of the {cands.wanted} candidates asked for were found "
                        f"({cands.drawn} configurations drawn)")

    # Φ of every candidate, scaled with fixed characteristic scales
    monitor.step(0.25, "calibration Jacobian of the candidates")
    scales = characteristic_scales(robot, ident.free)
    phi, names = observation_matrix(robot, cands.Q, targets, ident=ident)
    A = (phi / scales).reshape(len(cands), 3 * len(targets), L)
    sel = _Selector(A, index, monitor.sub(0.3, 0.55))
    all_info = sel.G.sum(axis=0)
    lam, V = np.linalg.eigh(all_info)
    if not lam[0] > 1e-9 * lam[-1]:
        weak = np.abs(V[:, 0])
        who = [names[k] for k in np.argsort(-weak)[:4] if weak[k] > 0.2]
        raise RoboCalError(
            f"the {len(cands)} candidate poses together cannot determine {', '.join(who) or 'every parameter'}",
            hint="Widen the joint ranges (smaller margins), or check the visibility constraints and the "
                 "robot base pose in robot.json.")

    # greedy + exchange
    chosen = sel.greedy(count)
    sel.monitor = monitor.sub(0.55, 0.8)
    chosen, exchanges = sel.exchange(chosen, max_depth=max_depth)

    # curve: shrink to n_min, grow beyond N
    monitor.step(0.8, "index versus the number of poses")
    n_max = min(len(cands), curve_max if curve_max is not None else count + max(10, count // 2))
    n_max = max(n_max, count)
    smaller = sel.shrink(chosen, n_min)
    sel.monitor = monitor.sub(0.8, 0.92)
    larger = []
    grow = list(chosen)
    while len(grow) < n_max:
        sel.monitor.step((len(grow) - count) / max(n_max - count, 1), f"curve: {len(grow) + 1} poses")
        grow = grow + [sel.best_add(grow)]
        larger.append(grow)
    sets = smaller[::-1] + [chosen] + larger
    n_points_per_pose = len(targets)
    ns = np.array([len(s) for s in sets])
    lam_sets = np.linalg.eigvalsh(np.stack([sel.info(s) for s in sets]))
    curve_sel = {k: np.array([indices_from_eigenvalues(l, n * n_points_per_pose)[k] for l, n in zip(lam_sets, ns)])
                 for k in INDEXES}
    rng = np.random.default_rng(np.random.SeedSequence([int(seed), 6]))
    med, q25, q75 = ({k: np.zeros(len(ns)) for k in INDEXES} for _ in range(3))
    rand_vals = None
    for j, n in enumerate(ns):
        monitor.step(0.92 + 0.05 * j / len(ns), "random selections")
        vals = random_indices(sel.G, int(n), random_trials, rng, n_points_per_pose)
        if n == count:
            rand_vals = vals
        for k in INDEXES:
            med[k][j], q25[k][j], q75[k][j] = np.percentile(vals[k], [50, 25, 75])
    random_cmp = RandomComparison(random_trials, {k: float(np.median(rand_vals[k])) for k in INDEXES}, rand_vals)
    curve = IndexCurve(ns, curve_sel, med, q25, q75, count)

    # order for short travel
    monitor.step(0.97, "ordering the poses")
    chosen = np.array(chosen, dtype=int)
    q_sel = robot.q_to_file(cands.Q[chosen]).reshape(len(chosen), robot.dof)
    home = robot.q_to_file(home_configuration(robot))
    before = path_length(q_sel, home, metric)
    order = order_poses(q_sel, home, metric)
    chosen = chosen[order]
    q_sel = q_sel[order]
    after = path_length(q_sel, home, metric)

    # final figures from scratch
    Q = cands.Q[chosen]
    phi_sel, _ = observation_matrix(robot, Q, targets, ident=ident)
    indices = observability_indices(phi_sel, n_points=len(Q) * len(targets), scales=scales)
    monitor.step(1.0, "done")
    return PoseSelectionResult(
        robot=robot, index=index, count=count, Q=Q, q_file=q_sel, candidate_index=chosen, candidates=cands,
        targets=targets, parameters=list(names), scales=scales, indices=indices, random=random_cmp, curve=curve,
        travel_before=before, travel_after=after, travel_metric=metric, home_file=home, n_min=n_min,
        recommended=recommended, exchanges=exchanges, seed=seed, seconds=time.perf_counter() - t0,
        marker=cands.marker[chosen], depth=None if cands.depth is None else cands.depth[chosen],
        warnings=warnings)


def write_selection(result: PoseSelectionResult, path: str | Path) -> Path:
    """Write the selected poses (visiting order) to poses.csv atomically; remembers the path."""
    result.path = write_poses(path, result.q_file)
    return result.path
