"""The Compensation page's status lines: (text, ok) for what a task brought back."""
from __future__ import annotations

import numpy as np

from app.jobs import compensation as job

MISSING = "No calibrated robot in the project (calibrated.json). Run the Identification step first."


def points_added(points: list[job.CompensatedPoint]) -> tuple[str, bool]:
    """A typed point computed, or a program's points."""
    bad = [p for p in points if not p.reachable]
    if len(points) == 1:
        p = points[0]
        return (f"✗ {p.name}: {p.note}" if bad else
                f"✓ {p.name}: corrected joints computed; predicted error {p.predicted_mm:.3f} mm "
                f"(1σ from the calibration).", not bad)
    return (f"✓ {len(points)} points of the program computed"
            + (f"; {len(bad)} cannot be reached with the calibrated model (see the notes)." if bad else "."), not bad)


def landed(point: job.CompensatedPoint, nominal: bool) -> tuple[str, bool]:
    """Where the marker landed after Go to point (with the nominal or the calibrated model)."""
    model = "nominal" if nominal else "calibrated"
    if not np.isfinite(point.error_mm(nominal)):
        return (f"⚠ {point.name}: the robot moved but the cameras did not find the marker "
                f"({point.measured_by}).", False)
    predicted = "" if nominal else f" (predicted {point.predicted_mm:.3f} mm, 1σ)"
    return (f"✓ {point.name}, {model} model: the marker landed {point.error_mm(nominal):.3f} mm from "
            f"the target{predicted}; measured: {point.measured_by}.", True)


def map_measured(run: job.MapRun) -> tuple[str, bool]:
    """The accuracy map's figures, and whether it was written."""
    ok = bool(run.amap.both.any()) and not run.amap.cancelled
    return (("✓ " if ok else "⚠ ") + run.amap.summary()
            + (f" Wrote {run.path.name}." if run.path is not None else " Nothing written."), ok)
