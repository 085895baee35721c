"""The look of RoboCal's pyqtgraph plots: white background, dark axes, labelled units.

Set per plot (no global pyqtgraph configuration, so other widgets keep theirs)."""
from __future__ import annotations

import math

import pyqtgraph as pg
from PySide6.QtGui import QFont

BACKGROUND = "w"
AXIS = "#5f6368"
TEXT = "#202124"
GRID_ALPHA = 0.25
BEFORE = "#e37400"          # orange: nominal model (before calibration)
AFTER = "#1a73e8"           # blue: calibrated model (after calibration)
HELD_OUT = "#188038"


class ReadableAxis(pg.AxisItem):
    """An axis whose logarithmic mode labels only 1, 2 and 5 times a power of ten (pyqtgraph
    labels every minor tick when the range spans few decades, and the labels overlap)."""

    def logTickStrings(self, values, scale, spacing):
        out = []
        for v in values:
            x = 10.0 ** (v * scale)
            if not math.isfinite(x) or x <= 0:
                out.append("")
                continue
            mantissa = x / 10.0 ** math.floor(math.log10(x) + 1e-9)
            out.append(f"{x:g}" if any(abs(mantissa - k) < 1e-6 * k for k in (1, 2, 5)) else "")
        return out


def readable_axes() -> dict:
    """axisItems= for a PlotWidget / PlotItem with readable logarithmic labels."""
    return {"left": ReadableAxis("left"), "bottom": ReadableAxis("bottom")}



def style_plot(plot: pg.PlotItem, x_label: str, y_label: str, title: str | None = None) -> None:
    font = QFont()
    font.setPointSizeF(8.5)
    for name in ("left", "bottom"):
        axis = plot.getAxis(name)
        axis.setPen(pg.mkPen(AXIS))
        axis.setTextPen(pg.mkPen(TEXT))
        axis.setTickFont(font)
        axis.enableAutoSIPrefix(False)
    plot.setLabel("bottom", x_label, color=TEXT, size="9pt")
    plot.setLabel("left", y_label, color=TEXT, size="9pt")
    if title:
        plot.setTitle(title, color=TEXT, size="9.5pt")
    plot.showGrid(x=True, y=True, alpha=GRID_ALPHA)
    plot.setMenuEnabled(False)
    plot.hideButtons()


def legend(plot: pg.PlotItem, offset=(-10, 10)) -> pg.LegendItem:
    """A legend in the top right corner with a light frame."""
    item = plot.addLegend(offset=offset, labelTextColor=TEXT, labelTextSize="8.5pt",
                          brush=pg.mkBrush(255, 255, 255, 220), pen=pg.mkPen("#dadce0"))
    return item


def colour(hex_colour: str, alpha: int = 255):
    c = pg.mkColor(hex_colour)
    c.setAlpha(alpha)
    return c
