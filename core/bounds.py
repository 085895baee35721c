"""Plausibility bounds: the largest values RoboCal accepts for each kind of quantity, and why.

A value outside its bound is no real robot's, camera's or lab's, and letting it through only
leads to overflow, a numerical routine that never ends, or a silently absurd result (one
measured x of 1e100 mm once gave "RMS 1.5e99 mm" and a calibrated file). Every reader and
option checks its numbers against these, with a message that names the file and the field.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from core.errors import RoboCalError


@dataclass(frozen=True)
class Bound:
    lo: float
    hi: float
    unit: str
    reason: str

    def check(self, value: float, *, source=None, field: str | None = None, what: str = "") -> float:
        """`value` if finite and within [lo, hi]; otherwise a RoboCalError naming source and field."""
        if not math.isfinite(value) or not self.lo <= value <= self.hi:
            unit = f" {self.unit}" if self.unit else ""
            raise RoboCalError(f"{what or 'value'} {value:g}{unit} is outside {self.lo:g} … {self.hi:g}{unit} "
                               f"({self.reason})", source=source, field=field,
                               hint="Check the value and its unit.")
        return value


#: lengths: DH a and d, base and tool offsets, targets, measured positions
LENGTH_MM = Bound(-1e5, 1e5, "mm", "a robot cell is a few metres across; 100 m is no arm's")
#: angles: DH θ, α, β, rpy, joint values and limits of revolute joints
ANGLE_DEG = Bound(-3600.0, 3600.0, "degrees", "ten turns is more than any joint or frame turns")
#: standard deviation of one measured coordinate
SIGMA_MM = Bound(1e-9, 1e3, "mm", "a point known to worse than a metre is no measurement")
#: pose ids in measurement and pose files
POSE_ID = Bound(0, 1e9, "", "pose ids count poses; a billion is beyond any calibration")
#: measured points in one measurements file (memory and time of identification grow with them)
POINT_COUNT = Bound(1, 200_000, "", "a calibration uses hundreds of points; identifying 200 000 already takes minutes")
#: random seeds
SEED = Bound(0, 2**32 - 1, "", "seeds are non-negative 32-bit integers")
#: image noise of the virtual lab, grey levels (8-bit images)
NOISE_GREY = Bound(0.0, 64.0, "grey levels", "more noise than a quarter of the 8-bit range hides every edge")
#: candidate poses for pose selection (memory grows with candidates × parameters)
CANDIDATES = Bound(1, 200_000, "", "200 000 candidates already cover a 6-axis workspace densely; more only use memory")
#: random selections compared with the chosen one
RANDOM_TRIALS = Bound(1, 10_000, "", "10 000 random selections give the median to well under 1 %")
#: poses to select, simulate or measure
POSE_COUNT = Bound(1, 100_000, "", "a calibration uses tens to hundreds of poses")
#: image pairs to render
PAIR_COUNT = Bound(0, 1_000, "", "a stereo calibration uses 10–60 pairs")
#: Huber threshold, in multiples of the robust residual scale
HUBER_K = Bound(0.1, 100.0, "", "below 0.1 every point is an outlier; above 100 it does nothing")
#: physical sizes of markers and plates
SIZE_MM = Bound(1e-3, 1e4, "mm", "a marker or plate is between a micrometre and ten metres wide")
#: angles given as options (margins, view angles)
OPTION_ANGLE_DEG = Bound(0.0, 180.0, "degrees", "an angle between directions")
