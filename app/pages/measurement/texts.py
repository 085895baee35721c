"""The Measurement page's words: the inputs line, the summary, the rejection reasons."""
from __future__ import annotations

import re
from collections import Counter

import numpy as np

from app.html import esc
from app.jobs.measurement import MEASURED, PENDING, REJECTED, RUNNING, PoseRow

WARN = "#b06000"


def short(reason: str, n: int = 70) -> str:
    """`reason` on one line, cut to `n` characters."""
    reason = " ".join(str(reason).split())
    return reason if len(reason) <= n else reason[: n - 1] + "…"


def reason_key(reason: str) -> str:
    """A reason without its numbers (alike reasons are counted together)."""
    text = re.sub(r"\(.*?\)", "", reason or "no reason given")
    text = re.sub(r"-?\d+(\.\d+)?", "#", text)
    return " ".join(text.split())[:90]


def counts(rows: list[PoseRow]) -> Counter:
    """How many rows have each status."""
    return Counter(r.status for r in rows)


def sources_html(poses_label: str, marker: str, marker_ok: bool, stereo: str, stereo_ok: bool) -> str:
    """Poses · Marker · Stereo in one line; the missing ones in amber."""
    def part(name: str, text: str, ok: bool) -> str:
        return f"<b>{name}:</b> " + (esc(text) if ok else f"<span style='color:{WARN}'>{esc(text)}</span>")
    return " · ".join([f"<b>Poses:</b> {esc(poses_label or 'none')}", part("Marker", marker, marker_ok),
                       part("Stereo", stereo, stereo_ok)])


def summary_html(rows: list[PoseRow], n_min: int) -> str:
    """Measured, rejected and pending poses, what identification needs, the commonest
    rejection reasons and the median predicted σ (mm); empty without rows."""
    if not rows:
        return ""
    c = counts(rows)
    enough = n_min > 0 and c[MEASURED] >= n_min
    need = (f"Identification needs at least <b>{n_min}</b> poses: "
            + ("<span style='color:#188038'><b>enough</b></span>" if enough else
               f"<span style='color:{WARN}'>{max(n_min - c[MEASURED], 0)} more</span>")) if n_min else ""
    text = (f"<b>{c[MEASURED]}</b> measured · <b>{c[REJECTED]}</b> rejected · "
            f"<b>{c[PENDING] + c[RUNNING]}</b> pending of {len(rows)} poses. {need}")
    reasons = Counter(reason_key(r.reason) for r in rows if r.status == REJECTED)
    if reasons:
        text += "<br>Rejected: " + "; ".join(f"{n}× {esc(k)}" for k, n in reasons.most_common(4))
    sig = [float(np.linalg.norm(r.sigma)) for r in rows if r.status == MEASURED and r.sigma is not None]
    if sig:
        text += f"<br>Median predicted σ of the measured points: {np.median(sig):.3f} mm."
    return text


def ready_text(rows: list[PoseRow], n_min: int, file_problem: str, complete: bool, teach: bool = False) -> str:
    """The status line before a run: what the files hold and what Start (or, in teach mode,
    Record pose) will do."""
    c = counts(rows)
    pending = c[PENDING] + c[RUNNING]
    if file_problem:
        return (f"The existing measurements cannot be used: {file_problem} Start over moves "
                "them aside (kept) and measures this pose list.")
    if not pending and c[MEASURED]:
        return (f"{'✓ ' if complete else ''}All {len(rows)} poses done: {c[MEASURED]} measured, "
                f"{c[REJECTED]} rejected." + ("" if complete else f" Identification needs {n_min}."))
    if teach:
        return ("Teach mode: bring the robot to the pose shown below, then Record pose. Each pose is written "
                "to measurements.csv as it is recorded.")
    if c[MEASURED] or c[REJECTED]:
        return (f"{c[MEASURED] + c[REJECTED]} of {len(rows)} poses done in an earlier run: Measure "
                "the rest measures the others.")
    return ("Start drives the robot through the poses; each measurement is written to "
            "measurements.csv as it is taken. Esc stops the robot.")
