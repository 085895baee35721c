"""The Check page's words that several of its parts say: what is missing, a check's verdict in
one line, and where a check on the virtual lab measured."""
from __future__ import annotations

MISSING = "No calibrated robot in the project (calibrated.json). Run the Identification step first."
NO_PROJECT = "No project: choose one in the Setup step."


def short_verdict(result) -> str:
    """One line: within or out of limits, the RMS error against its limit, how many poses are out."""
    if result.cancelled or not result.points:
        return result.verdict()
    out = sum(not p.within for p in result.points)
    text = (f"Check {'within limits' if result.within else 'OUT OF LIMITS'}: RMS error {result.rms_mm:.3f} mm "
            f"(limit {result.rms_limit_mm:.3f} mm); {out} of {len(result.points)} poses beyond their limits")
    return text + (f"; {len(result.missing)} not measured." if result.missing else ".")


def measured_on_lab(images) -> str:
    """Where a check on the virtual lab measures: through its cameras' images (`images`: trained
    marker and stereo rectification) or ideal measurements (None)."""
    return ("measured on the virtual lab, through its cameras' images (trained marker, stereo calibration)"
            if images is not None else
            "measured on the virtual lab, ideal measurements (no trained marker or stereo calibration in the "
            "project)")
