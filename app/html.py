"""Small helpers for the rich text the pages show (Qt's HTML subset): escaping and numbers."""
from __future__ import annotations

import html
import math


def esc(text) -> str:
    """`text` made safe for Qt rich text."""
    return html.escape(str(text))


def number(value: float | None, digits: int = 3, unit: str = "") -> str:
    """`value` with `digits` decimals (and a unit), or an em dash when it is missing or not finite."""
    if value is None or not math.isfinite(value):
        return "—"
    return f"{value:.{digits}f}" + (f" {unit}" if unit else "")
