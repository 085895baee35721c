"""A grid of targets inside the calibrated workspace, for the accuracy map.

The calibrated workspace is where the marker was measured during the calibration: the marker
positions of the calibrated model at the measured joint values. The grid is regular in the robot
base frame (DH frame 0 of the calibrated model: x, y horizontal for a floor-mounted robot, z up)
over the central part of that cloud; of its nodes, those nearest a measured marker position are
kept, so every target lies where the calibration saw the marker. Each node is reached with the
calibrated model from the joints of its nearest measured pose (position only: the tool keeps
about that pose's orientation, so the marker faces the cameras as it did there); nodes out of
reach or the joint limits, or refused by `keep` (e.g. the marker out of the cameras' view), are
left out.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from core.compensation.ik import solve_ik, tcp_poses
from core.errors import RoboCalError
from core.robot.model import RobotModel

LAYERS = 2              # grid planes along the base frame's z
CENTRAL = (20.0, 80.0)  # percentiles of the measured cloud the grid spans, per base axis
LIMIT_MARGIN = 0.05      # rad / mm kept from the joint limits, so the nominal model's joints stay inside too
CANDIDATES = 4          # grid nodes made per target asked for (the nearest reachable ones are kept)


@dataclass
class WorkspaceGrid:
    """Targets of an accuracy map: the `target` point (a tool point of the model) at `points`
    (n, 3) mm, measurement frame; `hints` (n, dof) rad / mm: the calibrated model's joints there."""

    points: np.ndarray
    hints: np.ndarray
    target: str


def workspace_grid(model: RobotModel, Q_measured, *, count: int = 20, target: str = "marker",
                   keep: Callable[[np.ndarray], np.ndarray] | None = None) -> WorkspaceGrid:
    """Up to `count` targets on a regular grid in the workspace the calibration measured with
    `model` (the calibrated robot) at the joint values `Q_measured` (m, dof) rad / mm; `keep(Q)`
    (k, dof) → (k,) bool refuses joints (None: all reachable nodes are kept)."""
    Q = np.atleast_2d(np.asarray(Q_measured, dtype=float))
    if target not in model.targets:
        raise RoboCalError(f"the robot has no target '{target}'", field="targets",
                           hint="Use the calibrated robot file of the project (it names its marker targets).")
    if len(Q) < 4 or count < 1:
        raise RoboCalError(f"{len(Q)} measured poses are too few to span a workspace", field="measurements",
                           hint="Measure the calibration poses first (Measurement step).")
    base_inv = np.linalg.inv(model.base)
    T = tcp_poses(model, Q, target)
    world = T[:, :3, 3]
    local = world @ base_inv[:3, :3].T + base_inv[:3, 3]
    lo, hi = np.percentile(local, CENTRAL, axis=0)
    span = np.maximum(hi - lo, 1.0)
    per_layer = int(np.ceil(CANDIDATES * count / LAYERS))       # more nodes than needed: keep the nearest
    nx = max(2, int(round(np.sqrt(per_layer * span[0] / span[1]))))
    ny = max(2, int(np.ceil(per_layer / nx)))
    gx, gy, gz = np.meshgrid(np.linspace(lo[0], hi[0], nx), np.linspace(lo[1], hi[1], ny),
                             np.linspace(lo[2], hi[2], LAYERS), indexing="ij")
    nodes = np.column_stack([gx.ravel(), gy.ravel(), gz.ravel()])
    distance = np.linalg.norm(nodes[:, None, :] - local[None, :, :], axis=2)
    nearest = distance.argmin(axis=1)
    order = np.argsort(distance[np.arange(len(nodes)), nearest], kind="stable")
    points = nodes[order] @ model.base[:3, :3].T + model.base[:3, 3]
    solved = solve_ik(model, points, tcp=target, frame="measurement", hint=Q[nearest[order]])
    good = solved.ok & model.within_limits(solved.Q, LIMIT_MARGIN) & (keep(solved.Q) if keep is not None else True)
    chosen = np.flatnonzero(good)[:count]
    chosen = chosen[np.lexsort(nodes[order][chosen].T[::-1])]      # grid order: by base x, then y, then z
    return WorkspaceGrid(points[chosen], solved.Q[chosen], target)
