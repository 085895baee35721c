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
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Sequence

import numpy as np

from core.errors import RoboCalError
from core.measurement.file import Measurements
from core.robot.model import RobotModel


@dataclass
class PlacedTarget:
    """A target placed on the tool: its offset (mm, tool frame), how, and from which poses."""

    name: str
    offset: np.ndarray
    references: list[str] = field(default_factory=list)     # empty: placed by the model alone
    poses: list[int] = field(default_factory=list)
    spread_mm: float = 0.0      # largest distance of one placement from their mean (0 for one)

    @property
    def how(self) -> str:
        if not self.references:
            return "from the model alone"
        return "relative to " + ", ".join(self.references)

    def summary(self) -> dict:
        return {"target": self.name, "offset_mm": [float(v) for v in self.offset], "references": list(self.references),
                "poses": [int(p) for p in self.poses], "spread_mm": self.spread_mm}


def place_targets(model: RobotModel, meas: Measurements, *, references: Sequence[str] = (),
                  names: Sequence[str] | None = None) -> tuple[RobotModel, list[PlacedTarget]]:
    """A copy of `model` with the targets of `meas` it does not know (or only `names`) placed on the
    tool, and how each was placed. With `references` (targets of the model, each
    measured in every pose of a placed target) the placement is relative; without, absolute.
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
        candidates = []
        for i in rows:
            T = model.fk(meas.Q[i])
            R, o = T[:3, :3], T[:3, 3]
            if not references:
                candidates.append(R.T @ (meas.xyz[i] - o))
                continue
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
                candidates.append(model.targets[r] + R.T @ (meas.xyz[i] - meas.xyz[j]))
        c = np.array(candidates)
        offset = c.mean(axis=0)
        out.targets[name] = offset
        if model.tools and name not in {t for ts in model.tools.values() for t in ts}:
            tool = model.tool_of(references[0]) if references else next(iter(model.tools))
            out.tools[tool] = list(out.tools[tool]) + [name]
        placed.append(PlacedTarget(name, offset, list(references), sorted({int(meas.pose[i]) for i in rows}),
                                   float(np.max(np.linalg.norm(c - offset, axis=1)))))
    return out, placed


def _row_of(meas: Measurements, pose: int, target: str) -> int | None:
    hits = np.flatnonzero((meas.pose == pose) & (np.array(meas.target) == target))
    return int(hits[0]) if len(hits) else None
