"""A "true" robot that bends under its weight: seeded deflection coefficients for the virtual lab.

Each of the default terms (core.robot.compliance.DEFAULT_TERMS: J2 follows sin/cos of q2 and of
q2 + q3, J3 sin/cos of q2 + q3) gets a coefficient drawn uniformly in DEFLECTION_RANGE_DEG with a
random sign — about what a small industrial arm shows (the ABB IRB 120 laser-tracker data give
0.01–0.08°): at 500 mm from the shoulder, 0.05° is 0.4 mm.
"""
from __future__ import annotations

import numpy as np

from core.robot.compliance import DEFAULT_TERMS, Compliance
from core.robot.model import RobotModel

DEFLECTION_RANGE_DEG = (0.02, 0.08)


def deflecting_robot(true: RobotModel, rng: np.random.Generator | int | None = 0, *,
                     range_deg=DEFLECTION_RANGE_DEG) -> RobotModel:
    """A copy of `true` with seeded deflection coefficients (rad inside the model)."""
    rng = np.random.default_rng(rng)
    out = true.copy()
    out.compliance = Compliance.zero(true.dof)
    lo, hi = np.deg2rad(range_deg[0]), np.deg2rad(range_deg[1])
    for joint, shape in DEFAULT_TERMS:
        out.compliance.set(joint, shape, float(rng.uniform(lo, hi) * rng.choice([-1.0, 1.0])))
    return out
