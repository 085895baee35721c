"""An order of the selected poses that keeps robot travel short.

Distance between two configurations (file units: degrees for revolute joints, mm for
prismatic ones), `metric`:
* "max" (default): the largest joint move, max_j |Δq_j| / w_j — proportional to the time of a
  synchronised point-to-point move when every joint runs at the same top speed (the usual
  PTP motion of robot controllers: all joints start and stop together, the slowest decides);
* "euclidean": sqrt(Σ_j (Δq_j / w_j)²).
`weights` w_j default to 1 (a joint that is twice as fast gets w = 2).

The path starts at `start` (default: the home configuration, every joint at 0 clipped to its
limits) and visits every pose once without returning (an open path). It is built by
nearest-neighbour from the start, then improved by 2-opt (reversing a stretch of the path
whenever that shortens it) until no reversal helps. Deterministic.
"""
from __future__ import annotations

import numpy as np

from core.robot.model import RobotModel

METRICS = ("max", "euclidean")


def distance_matrix(points: np.ndarray, metric: str = "max", weights=None) -> np.ndarray:
    """Pairwise distances of configurations (k, n) in file units -> (k, k)."""
    P = np.asarray(points, dtype=float)
    w = np.ones(P.shape[1]) if weights is None else np.asarray(weights, dtype=float)
    diff = np.abs(P[:, None, :] - P[None, :, :]) / w
    if metric == "max":
        return diff.max(axis=-1)
    if metric == "euclidean":
        return np.sqrt(np.einsum("ijk,ijk->ij", diff, diff))
    raise ValueError(f"unknown metric {metric!r}; use one of {METRICS}")


def home_configuration(robot: RobotModel) -> np.ndarray:
    """Every joint at 0, clipped to its limits (internal units)."""
    lo, hi = robot.limits()
    return np.clip(np.zeros(robot.dof), lo, hi)


def path_length(Q_file: np.ndarray, start=None, metric: str = "max", weights=None) -> float:
    """Travel through the configurations in the given order (file units), from `start` if given."""
    P = np.asarray(Q_file, dtype=float)
    if start is not None:
        P = np.vstack([np.asarray(start, dtype=float)[None, :], P])
    if len(P) < 2:
        return 0.0
    D = distance_matrix(P, metric, weights)
    return float(sum(D[i, i + 1] for i in range(len(P) - 1)))


def _two_opt(order: list[int], D: np.ndarray) -> list[int]:
    """2-opt on an open path whose first node (order[0]) is fixed."""
    n = len(order)
    improved = True
    while improved:
        improved = False
        for i in range(1, n - 1):
            a, b = order[i - 1], order[i]
            for j in range(i + 1, n):
                c = order[j]
                d = order[j + 1] if j + 1 < n else None
                before = D[a, b] + (D[c, d] if d is not None else 0.0)
                after = D[a, c] + (D[b, d] if d is not None else 0.0)
                if after < before - 1e-9:
                    order[i:j + 1] = order[i:j + 1][::-1]
                    improved = True
                    a, b = order[i - 1], order[i]
    return order


def order_poses(Q_file: np.ndarray, start=None, metric: str = "max", weights=None) -> np.ndarray:
    """Indices ordering the configurations (k, n; file units) for a short open path from
    `start` (file units; default q = 0), which is not part of the result. Nearest neighbour,
    then 2-opt."""
    P = np.asarray(Q_file, dtype=float)
    k = len(P)
    if k <= 1:
        return np.arange(k)
    s = np.zeros(P.shape[1]) if start is None else np.asarray(start, dtype=float)
    nodes = np.vstack([s[None, :], P])             # node 0 is the start
    D = distance_matrix(nodes, metric, weights)
    order = [0]
    left = set(range(1, k + 1))
    while left:
        last = order[-1]
        nxt = min(left, key=lambda j: (D[last, j], j))
        order.append(nxt)
        left.remove(nxt)
    order = _two_opt(order, D)
    return np.array(order[1:]) - 1
