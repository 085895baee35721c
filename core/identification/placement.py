"""Placing a new target on the tool from one measurement: relative to a calibrated target, or
from the model alone.

A target measured once (a reflector mounted after calibration, a probe tip) has to be given an
offset on the tool before the model can predict it. Two ways, from a pose q where it was measured
at x_new (mm, measurement frame):

* absolute (from the model alone): t = T(q)⁻¹·x_new. Whatever error the model has at q — base,
  geometry, deflection — goes into t and comes back in every later prediction;
* relative to a calibrated target r measured in the same pose at x_r:
      t = t_r + R(q)ᵀ·(x_new − x_r)
  The model's position error at q is common to both points and cancels; only its orientation
  error at q (small over the short distance between the two targets) remains. With several
  reference targets (or several poses) the placements are averaged.

R(q), T(q): the model's tool pose (deflection included) at q; t, t_r in the tool frame (mm).

Uncertainty of a placed target (with the calibration's `uncertainty`): t is a function of the
calibrated parameters θ (t_r, and everything in R(q), T(q)) and of the measurements x (noise σ
per axis each), so  δt = G·δθ + A·n  with G = ∂t/∂θ (central differences, the parameters'
internal units) and A = ∂t/∂x (R(q)ᵀ and −R(q)ᵀ for a relative placement from one pose: its
noise part is 2σ²·I). The placed target joins the parameters with the covariance
      [[C, C·Gᵀ], [G·C, G·C·Gᵀ + σ²·A·Aᵀ]]
so a prediction of it (a check's limits) carries the calibrated target's uncertainty, the
model's at q, and the two measurements' noise, correlated with the rest as they are.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Protocol, Sequence

import numpy as np

from core.errors import RoboCalError
from core.kinematics.jacobian import Parameter, apply_step
from core.measurement.file import Measurements
from core.robot.model import RobotModel

#: central-difference step of ∂t/∂θ (mm or rad): the placement is smooth, FK exact to ~1e-12 mm
STEP = 1e-6


@dataclass
class PlacedTarget:
    """A target placed on the tool: its offset (mm, tool frame), how, and from which poses."""

    name: str
    offset: np.ndarray
    references: list[str] = field(default_factory=list)     # empty: placed by the model alone
    poses: list[int] = field(default_factory=list)
    spread_mm: float = 0.0      # largest distance of one placement from their mean (0 for one)
    covariance: np.ndarray | None = None     # (3, 3) mm², tool frame; None: no calibration uncertainty given

    @property
    def how(self) -> str:
        if not self.references:
            return "from the model alone"
        return "relative to " + ", ".join(self.references)

    @property
    def sigma_mm(self) -> float | None:
        """The placed offset's standard deviation per axis (mm, RMS over x, y, z); None without one."""
        return None if self.covariance is None else float(np.sqrt(np.trace(self.covariance) / 3.0))

    def summary(self) -> dict:
        out = {"target": self.name, "offset_mm": [float(v) for v in self.offset], "references": list(self.references),
               "poses": [int(p) for p in self.poses], "spread_mm": self.spread_mm}
        if self.covariance is not None:
            out["sigma_mm"] = self.sigma_mm
        return out


class Uncertainty(Protocol):
    """What placing needs of a calibration's uncertainty (core.monitoring.uncertainty's
    CalibrationUncertainty): the estimated parameters, their covariance (internal units) and
    the measurement noise σ (mm per axis)."""

    parameters: list[Parameter]
    covariance: np.ndarray
    sigma_mm: float


def place_targets(model: RobotModel, meas: Measurements, *, references: Sequence[str] = (),
                  names: Sequence[str] | None = None, uncertainty: Uncertainty | None = None
                  ) -> tuple[RobotModel, list[PlacedTarget]]:
    """A copy of `model` with the targets of `meas` it does not know (or only `names`) placed on the
    tool, and how each was placed. With `references` (targets of the model, each
    measured in every pose of a placed target) the placement is relative; without, absolute.
    With the calibration's `uncertainty` each placed target gets its covariance (see the module),
    and the copy's `calibration.covariance` holds the placed targets' offsets as parameters, so
    what reads the calibration's uncertainty from the copy (a check's limits) predicts them too.
    Raises RoboCalError naming the file, the target and the pose when a reference is missing."""
    source = meas.source or None
    for r in references:
        if r not in model.targets:
            raise RoboCalError(f"the reference target '{r}' is not in the robot '{model.name}'", source=source,
                               field="--relative-to", hint="Give a target of the calibrated robot file.")
    meas = meas if meas.Q is not None and meas.Q.shape[1] == model.dof else meas.with_robot(model)
    wanted = [t for t in (names if names is not None else [t for t in meas.target_names if t not in model.targets])
              if t not in set(references)]
    if not wanted:
        raise RoboCalError(f"no target to place: every measured target is already in the robot '{model.name}'",
                           source=source, hint="Measure the new target in the same pose as the reference target.")
    out = model.copy()
    placed = []
    for name in wanted:
        rows = np.flatnonzero(np.array(meas.target) == name)
        if not len(rows):
            raise RoboCalError(f"target '{name}' is not measured", source=source, field=name)
        pairs = _pairs(meas, name, rows, references)
        c = _candidates(model, meas, pairs)
        offset = c.mean(axis=0)
        out.targets[name] = offset
        if model.tools and name not in {t for ts in model.tools.values() for t in ts}:
            tool = model.tool_of(references[0]) if references else next(iter(model.tools))
            out.tools[tool] = list(out.tools[tool]) + [name]
        placed.append(PlacedTarget(name, offset, list(references), sorted({int(meas.pose[i]) for i in rows}),
                                   float(np.max(np.linalg.norm(c - offset, axis=1)))))
    if uncertainty is not None:
        _propagate(model, meas, references, placed, out, uncertainty)
    return out, placed


def _pairs(meas: Measurements, name: str, rows, references: Sequence[str]) -> list[tuple[int, int | None, str]]:
    """(row of the placed target, row of the reference measured in the same pose and its name,
    or None and "" when placed from the model alone), one per placement to average; RoboCalError when a reference
    was not measured in that pose or the joints moved between the two."""
    source = meas.source or None
    if not references:
        return [(int(i), None, "") for i in rows]
    out = []
    for i in rows:
        for r in references:
            j = _row_of(meas, int(meas.pose[i]), r)
            if j is None:
                raise RoboCalError(f"pose {int(meas.pose[i])} measures '{name}' but not the reference '{r}'",
                                   source=source, field=r,
                                   hint=f"Measure '{r}' in the same pose as '{name}', or place it without "
                                        f"--relative-to.")
            if not np.allclose(meas.Q[j], meas.Q[i]):
                raise RoboCalError(f"pose {int(meas.pose[i])}: '{name}' and '{r}' have different joint values",
                                   source=source, field=r, hint="Both must be measured without moving the robot.")
            out.append((int(i), j, r))
    return out


def _candidates(model: RobotModel, meas: Measurements, pairs) -> np.ndarray:
    """One placement (3,) per pair (see _pairs), mm in the tool frame, with `model`."""
    out = []
    for i, j, r in pairs:
        T = model.fk(meas.Q[i])
        R, o = T[:3, :3], T[:3, 3]
        if j is None:
            out.append(R.T @ (meas.xyz[i] - o))
        else:
            out.append(model.targets[r] + R.T @ (meas.xyz[i] - meas.xyz[j]))
    return np.array(out)


def _propagate(model: RobotModel, meas: Measurements, references: Sequence[str], placed: list[PlacedTarget],
               out: RobotModel, unc: Uncertainty) -> None:
    """Each placed target's covariance, and the copy's calibration covariance extended with
    their offsets (see the module)."""
    # a target placed again replaces its calibrated offset: it does not depend on it
    again = {p.name for p in placed}
    keep = [k for k, prm in enumerate(unc.parameters) if not (prm.group == "target" and prm.target in again)]
    params = [unc.parameters[k] for k in keep]
    C = np.asarray(unc.covariance, dtype=float)[np.ix_(keep, keep)]
    G, N = [], []
    for p in placed:
        rows = np.flatnonzero(np.array(meas.target) == p.name)
        pairs = _pairs(meas, p.name, rows, references)
        g = np.zeros((3, len(params)))
        for k in range(len(params)):
            step = np.zeros(len(params))
            step[k] = STEP
            plus = _candidates(apply_step(model, params, step), meas, pairs).mean(axis=0)
            minus = _candidates(apply_step(model, params, -step), meas, pairs).mean(axis=0)
            g[:, k] = (plus - minus) / (2.0 * STEP)
        # ∂t/∂x of each measurement row the placement read: R(q)ᵀ/m for the new target, −R(q)ᵀ/m for a reference
        A: dict[int, np.ndarray] = {}
        for i, j, _ in pairs:
            Rt = model.fk(meas.Q[i])[:3, :3].T / len(pairs)
            A[i] = A.get(i, np.zeros((3, 3))) + Rt
            if j is not None:
                A[j] = A.get(j, np.zeros((3, 3))) - Rt
        n = unc.sigma_mm ** 2 * sum(a @ a.T for a in A.values())
        p.covariance = g @ C @ g.T + n
        G.append(g)
        N.append(n)
    G = np.vstack(G)
    joint = G @ C @ G.T
    for k in range(len(placed)):
        joint[3 * k:3 * k + 3, 3 * k:3 * k + 3] += N[k]
    full = np.block([[C, C @ G.T], [G @ C, joint]])
    names = [prm.name for prm in params] + [f"{p.name}.{axis}" for p in placed for axis in "xyz"]
    calibration = dict(out.calibration or {})
    covariance = dict(calibration.get("covariance") or {})
    covariance.update({"parameters": names, "units": "mm and rad", "matrix": (0.5 * (full + full.T)).tolist()})
    calibration["covariance"] = covariance
    out.calibration = calibration


def _row_of(meas: Measurements, pose: int, target: str) -> int | None:
    hits = np.flatnonzero((meas.pose == pose) & (np.array(meas.target) == target))
    return int(hits[0]) if len(hits) else None
