"""Where the marker method breaks: detection rate and 3D error against the truth while the light
dims, the marker is covered and it turns away from the cameras.

`robustness_sweep(lab, locator)` renders `pairs` stereo pairs of the marker plate for every value
of each condition (core.virtual_lab.conditions), the other conditions kept nominal, and locates
the marker in each. Pair i is drawn from the same generator at every value, so the values are
compared on the same places, depths and turns. A marker that is located (it passed every check of
the locator) more than `wrong_mm` from the truth is a silent wrong number: a calibration would use
it. There should be none; a marker that cannot be located well must be rejected with a reason.
"""
from __future__ import annotations

import re
from collections import Counter
from dataclasses import dataclass, field

import numpy as np

from core.task import Monitor
from core.virtual_lab.conditions import ImagingConditions, marker_pose

LIGHT = (1.0, 0.7, 0.5, 0.3, 0.2, 0.1)
OCCLUSION = (0.0, 0.1, 0.2, 0.3, 0.4, 0.5)
TILT = (0.0, 20.0, 40.0, 50.0, 60.0, 70.0, 75.0)
WRONG_MM = 2.0                  # a located marker farther than this from the truth is wrongly accepted


@dataclass
class RobustnessRow:
    """One condition value: `rendered` pairs, the 3D errors (mm) of the located ones and the
    reasons the others were rejected."""

    axis: str                   # "light", "occlusion" or "tilt"
    value: float
    rendered: int = 0
    errors: list = field(default_factory=list)
    reasons: Counter = field(default_factory=Counter)      # reason without its numbers -> count
    examples: dict = field(default_factory=dict)            # reason without its numbers -> first in full
    wrong_mm: float = WRONG_MM

    @property
    def located(self) -> int:
        return len(self.errors)

    @property
    def detection_rate(self) -> float:
        """Located and passing the checks / rendered (0 … 1)."""
        return self.located / self.rendered if self.rendered else float("nan")

    @property
    def median_error(self) -> float:
        return float(np.median(self.errors)) if self.errors else float("nan")

    @property
    def p95_error(self) -> float:
        return float(np.percentile(self.errors, 95)) if self.errors else float("nan")

    @property
    def top_reason(self) -> str:
        """The most frequent rejection, as first given in full ("" when none)."""
        return self.examples[self.reasons.most_common(1)[0][0]] if self.reasons else ""

    @property
    def wrong(self) -> int:
        """Located markers farther than `wrong_mm` from the truth: silent wrong numbers."""
        return int(np.sum(np.asarray(self.errors) > self.wrong_mm))

    def to_dict(self) -> dict:
        def num(v):
            return None if not np.isfinite(v) else round(float(v), 4)

        return {"axis": self.axis, "value": self.value, "rendered": self.rendered, "located": self.located,
                "detection_rate": num(self.detection_rate), "median_error_mm": num(self.median_error),
                "p95_error_mm": num(self.p95_error), "wrongly_accepted": self.wrong,
                "reasons": {self.examples.get(k, k): n for k, n in self.reasons.items()}}


@dataclass
class RobustnessTable:
    rows: list[RobustnessRow]
    pairs: int
    seed: int
    side: str
    wrong_mm: float = WRONG_MM

    def axis(self, name: str) -> list[RobustnessRow]:
        return [r for r in self.rows if r.axis == name]

    @property
    def wrong(self) -> int:
        return sum(r.wrong for r in self.rows)

    def text(self) -> str:
        lines = [f"{'condition':<22} {'pairs':>5} {'detected':>9} {'median 3D':>10} {'95th pct':>10} "
                 f"{'wrong':>6}  most frequent rejection"]
        for r in self.rows:
            label = condition_label(r.axis, r.value)
            med = f"{r.median_error:.3f} mm" if r.errors else "-"
            p95 = f"{r.p95_error:.3f} mm" if r.errors else "-"
            reason = r.top_reason[:70]
            lines.append(f"{label:<22} {r.rendered:>5d} {100 * r.detection_rate:>8.0f}% {med:>10} {p95:>10} "
                         f"{r.wrong:>6d}  {reason}")
        lines.append(f"wrong: located but more than {self.wrong_mm:g} mm from the truth (silent wrong numbers).")
        return "\n".join(lines)

    def to_dict(self) -> dict:
        return {"pairs": self.pairs, "seed": self.seed, "occlusion_side": self.side, "wrong_mm": self.wrong_mm,
                "wrongly_accepted": self.wrong,
                "units": {"light": "gain on the scene", "occlusion": "fraction of the outer square",
                          "tilt": "deg", "errors": "mm"},
                "rows": [r.to_dict() for r in self.rows]}


def condition_label(axis: str, value: float) -> str:
    """"light 0.3x", "occlusion 10 %" or "tilt 60°"."""
    if axis == "light":
        return f"light {value:g}x"
    if axis == "occlusion":
        return f"occlusion {100 * value:g} %"
    return f"tilt {value:g}°"


def robustness_sweep(lab, locator, *, light=LIGHT, occlusion=OCCLUSION, tilt=TILT, pairs: int = 20,
                     seed: int = 0, side: str = "corner", wrong_mm: float = WRONG_MM, progress=None,
                     cancelled=None) -> RobustnessTable:
    """Detection rate and 3D error (mm, left camera frame) of `locator` (a MarkerLocator) on
    `pairs` rendered pairs per value of `light` (gain), `occlusion` (fraction of the outer square,
    from `side`) and `tilt` (deg), each swept with the others nominal."""
    monitor = Monitor(progress, cancelled)
    plan = ([("light", float(v), ImagingConditions(light=float(v))) for v in light]
            + [("occlusion", float(v), ImagingConditions(occlusion=float(v), side=side)) for v in occlusion]
            + [("tilt", float(v), ImagingConditions(tilt=float(v))) for v in tilt])
    rows = [RobustnessRow(axis, value, wrong_mm=wrong_mm) for axis, value, _ in plan]
    total = max(len(plan) * pairs, 1)
    done = 0
    for row, (_, _, conditions) in zip(rows, plan):
        for i in range(pairs):
            monitor.step(done / total, f"{condition_label(row.axis, row.value)}: pair {i + 1} of {pairs}")
            _one(lab, locator, row, conditions, np.random.default_rng([seed, 41, i]),
                 np.random.default_rng([seed, 42, i]))
            done += 1
    monitor.step(1.0, "done")
    return RobustnessTable(rows, pairs, seed, side, wrong_mm)


def _one(lab, locator, row: RobustnessRow, conditions: ImagingConditions, pose_rng, image_rng) -> None:
    T = marker_pose(lab, pose_rng, conditions)
    left, right = lab.render_marker_at(T, image_rng, conditions=conditions)
    row.rendered += 1
    loc = locator.locate(left, right)
    if loc.ok:
        row.errors.append(float(np.linalg.norm(loc.point - T[:3, 3])))
    else:
        key = _short(loc.reason)
        row.reasons[key] += 1
        row.examples.setdefault(key, loc.reason)


def _short(reason: str) -> str:
    """A rejection reason without its numbers, so alike reasons count together."""
    text = re.sub(r"\(.*?\)", "", reason or "no reason given")
    text = re.sub(r"-?\d+(\.\d+)?", "#", text)
    return " ".join(text.split())[:110]
