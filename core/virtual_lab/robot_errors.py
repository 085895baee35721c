"""A "true" robot: the nominal model with realistic, seeded geometric errors.

Magnitudes (each drawn uniformly in the range, with a random sign):
  - link lengths d and a: 0.5–2 mm
  - link twists alpha: 0.1–0.5°; Hayati's beta on nearly parallel consecutive axes: 0.1–0.5°
  - joint zero offsets theta: 0.1–0.5°
  - marker target position: ~1 mm (random direction, length 0.5–1.5 mm)
On a nearly parallel pair (joint i with alpha_i ≈ 0) joint i gets Hayati's beta and its own d
is left exact: with parallel axes d_i is redundant with d_(i+1), and the identification keeps
d_i fixed beside beta_i (core/calibration_jacobian.py), so the true robot stays exactly
representable by the identification model.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from core.robot.model import RobotModel

LENGTH_RANGE = (0.5, 2.0)      # mm
ANGLE_RANGE_DEG = (0.1, 0.5)   # deg
TARGET_RANGE = (0.5, 1.5)      # mm


@dataclass
class RobotErrors:
    """The true robot and what was changed. Deltas are true − nominal (rad and mm);
    a parameter left unchanged has delta 0 and is not listed in `perturbed`."""

    robot: RobotModel
    delta: dict[str, np.ndarray] = field(default_factory=dict)   # "theta", "d", "a", "alpha", "beta": (n,)
    target_delta: dict[str, np.ndarray] = field(default_factory=dict)  # name -> (3,) mm
    perturbed: dict[str, np.ndarray] = field(default_factory=dict)  # parameter -> (n,) bool

    def to_dict(self) -> dict:
        """For truth files: deltas in mm and degrees."""
        out = {}
        for key, values in self.delta.items():
            scale = 1.0 if key in ("d", "a") else float(np.rad2deg(1.0))
            out[key] = [float(v * scale) for v in values]
        out["targets"] = {k: [float(x) for x in v] for k, v in self.target_delta.items()}
        out["units"] = {"length": "mm", "angle": "deg"}
        return out


def _signed(rng: np.random.Generator, lo: float, hi: float, n: int) -> np.ndarray:
    return rng.uniform(lo, hi, n) * rng.choice([-1.0, 1.0], n)


def perturb_robot(nominal: RobotModel, rng: np.random.Generator | int | None = 0, *,
                  length_range=LENGTH_RANGE, angle_range_deg=ANGLE_RANGE_DEG,
                  target_range=TARGET_RANGE, parallel_tolerance_deg: float = 5.0) -> RobotErrors:
    """A copy of `nominal` with seeded errors on every DH parameter and on the targets.

    Base and tool are left as they are (the virtual lab places the base itself)."""
    rng = np.random.default_rng(rng)
    n = nominal.dof
    lo_a, hi_a = np.deg2rad(angle_range_deg[0]), np.deg2rad(angle_range_deg[1])
    parallel = nominal.parallel_axis_joints(parallel_tolerance_deg)
    perturbed = {k: np.ones(n, bool) for k in ("theta", "d", "a", "alpha")}
    perturbed["beta"] = np.zeros(n, bool)
    for i in parallel:
        perturbed["beta"][i] = True
        perturbed["d"][i] = False
    # Draw every value in a fixed order so the result depends only on the seed.
    raw = {
        "theta": _signed(rng, lo_a, hi_a, n),
        "d": _signed(rng, *length_range, n),
        "a": _signed(rng, *length_range, n),
        "alpha": _signed(rng, lo_a, hi_a, n),
        "beta": _signed(rng, lo_a, hi_a, n),
    }
    delta = {k: np.where(perturbed[k], raw[k], 0.0) for k in raw}
    true = nominal.copy()
    for i, joint in enumerate(true.joints):
        for key in raw:
            setattr(joint, key, getattr(joint, key) + float(delta[key][i]))
    target_delta = {}
    for name in sorted(nominal.targets):
        direction = rng.normal(size=3)
        direction /= np.linalg.norm(direction)
        target_delta[name] = direction * rng.uniform(*target_range)
        true.targets[name] = np.asarray(nominal.targets[name], dtype=float) + target_delta[name]
    true.name = f"{nominal.name} (virtual lab, true geometry)"
    return RobotErrors(robot=true, delta=delta, target_delta=target_delta, perturbed=perturbed)
