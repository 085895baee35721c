"""The words and rich text of the Pose sequence page: the index names and the result in numbers."""
from __future__ import annotations

import math

from app.html import esc
from core.poses.selection import INDEXES, PoseSelectionResult, lower_is_better

INDEX_CHOICES = [
    ("cond", "Condition number κ (smaller is better)"),
    ("O1", "O1: D-optimal, volume of the error ellipsoid"),
    ("O3", "O3: E-optimal, smallest singular value"),
    ("O4", "O4: noise amplification index"),
    ("O5", "O5: A-optimal, mean variance"),
]
AXIS_LABELS = {     # Φ is scaled to mm of marker motion per mm (or per reach·rad): indices have no unit
    "cond": "condition number κ (–)",
    "O1": "O1, D-optimal (no unit)",
    "O3": "O3 = σ_min (no unit)",
    "O4": "O4 = σ_min²/σ_max (no unit)",
    "O5": "O5, A-optimal (no unit)",
}
SHORT = {"cond": "κ", "O1": "O1", "O3": "O3", "O4": "O4", "O5": "O5"}
PLACEHOLDER = ("<span style='color:#5f6368'>The plot will show how the chosen index improves as poses are "
               "added, next to random selections of the same size. The flatter the curve at N, the less "
               "more poses would help.</span>")


def significant(v: float | None) -> str:
    """An index with 3 significant digits (indices span decades), or a dash when it is missing."""
    return "–" if v is None or not math.isfinite(v) else f"{v:.3g}"


def comparison_html(r: PoseSelectionResult) -> str:
    """The selection against random selections, in words and a small table."""
    key = r.index
    v, med = r.value(key), r.random_median(key)
    better = (v < med) if lower_is_better(key) else (v > med)
    factor = (med / v if lower_is_better(key) else v / med) if v and med else math.nan
    head = (f"<b>{SHORT[key]} = {significant(v)}</b> for the {r.count} selected poses, against "
            f"{significant(med)} for the median of {r.random.trials} random selections of {r.count} from the "
            "same candidates: "
            + (f"<b>{factor:.2f}× {'better' if better else 'worse'}</b>." if math.isfinite(factor) else "."))
    rows = "".join(
        f"<tr><td>{SHORT[k]} {'↓' if lower_is_better(k) else '↑'}</td>"
        f"<td align='right'>{significant(r.value(k))}</td>"
        f"<td align='right'>{significant(r.random_median(k))}</td></tr>"
        for k in INDEXES)
    table = ("<table cellspacing='0' cellpadding='1'><tr><th align='left'>index&nbsp;</th>"
             "<th align='right'>&nbsp;selected</th><th align='right'>&nbsp;&nbsp;random</th></tr>"
             f"{rows}</table>")
    return f"{head}{table}<span style='color:#5f6368'>↓ smaller is better, ↑ larger is better.</span>"


def facts_html(r: PoseSelectionResult) -> str:
    """Candidates and rejections, travel (degrees of joint motion), the smallest N."""
    c = r.candidates
    rejected = ", ".join(f"{esc(k)} {n}" for k, n in c.rejected.items() if n) or "none"
    facts = (f"Candidates: {len(c)} feasible of {c.drawn} drawn (rejected: {rejected}). "
             f"Travel from home: {r.travel_before:.0f}° → <b>{r.travel_after:.0f}°</b> after ordering "
             f"(largest joint move per step, summed). {len(r.parameters)} identifiable parameters: at least "
             f"{r.n_min} poses, about {r.recommended} recommended.")
    warn = "".join(f" <span style='color:#8a4b00'>Note: {esc(w)}.</span>" for w in r.warnings)
    return facts + warn


def loaded_html(count: int, path) -> str:
    """A poses.csv read from the project (no selection run in this session)."""
    return f"{count} poses read from <code>{esc(path)}</code>."
