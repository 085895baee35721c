"""The plots of the SSD area correlation (chapter Fig. 16 and Fig. 17).

`CriteriaPlot.set_curve(disparities, criteria, ...)`: the criteria function C(d) of eq. (26)
(normalised per pixel) along the epipolar line, with its minimum (eq. 27) marked, the
second-best minimum (the reliability figure is their ratio) and, optionally, the curve the
search used (e.g. with a pre-warped window) dashed.

`WindowSweepPlot.set_sweep(sizes, minima, disparities, located)`: the minimum of the criteria
per square window size; a dot is green when that window's minimum is at the marker's disparity
and red when a small window found a lower minimum somewhere else (a wrong match).
"""
from __future__ import annotations

import math

import numpy as np
import pyqtgraph as pg
from PySide6.QtCore import Qt

from widgets.plot_theme import AFTER, AXIS, BEFORE, TEXT, colour, legend, style_plot

GOOD = "#188038"
BAD = "#d93025"
CRITERIA_UNIT = "SSD criteria (grey level², per pixel)"


def _finite_xy(x, y):
    x = np.asarray(x, dtype=float).reshape(-1)
    y = np.asarray(y, dtype=float).reshape(-1)
    ok = np.isfinite(x) & np.isfinite(y)
    return x[ok], y[ok]


class CriteriaPlot(pg.PlotWidget):
    """C(d) versus the disparity d (Fig. 16)."""

    def __init__(self, parent=None):
        super().__init__(parent=parent, background="w", enableMenu=False)
        self.setObjectName("criteriaPlot")
        self.plot_item = self.getPlotItem()
        style_plot(self.plot_item, "disparity (px)", CRITERIA_UNIT, "Criteria along the epipolar line (Fig. 16)")
        self.plot_item.getAxis("left").setWidth(64)     # room for the ticks and the label from the start
        self.legend = legend(self.plot_item)
        self.searched = pg.PlotDataItem(pen=pg.mkPen(colour(BEFORE, 200), width=1.2, style=Qt.PenStyle.DashLine),
                                        name="searched (window pre-warped by the marker plane)")
        self.curve = pg.PlotDataItem(pen=pg.mkPen(AFTER, width=1.6), name="C(d), eq. (26)")
        self.minimum = pg.PlotDataItem(pen=None, symbol="o", symbolSize=10, symbolBrush=colour(GOOD),
                                       symbolPen=pg.mkPen("w", width=1.2), name="minimum d*, eq. (27)")
        self.second = pg.PlotDataItem(pen=None, symbol="t", symbolSize=10, symbolBrush=colour(BAD, 200),
                                      symbolPen=pg.mkPen("w", width=1), name="second-best minimum")
        self.line = pg.InfiniteLine(angle=90, pen=pg.mkPen(GOOD, width=1, style=Qt.PenStyle.DotLine),
                                    label="", labelOpts={"position": 0.92, "color": TEXT, "fill": (255, 255, 255, 200),
                                                         "anchors": [(0, 0), (0, 0)]})
        for item in (self.searched, self.curve, self.second, self.minimum):
            self.addItem(item)
        self.addItem(self.line)
        self.line.hide()
        self.searched.hide()

    def set_curve(self, disparities, criteria, *, minimum: tuple[float, float] | None = None,
                  second: tuple[float, float] | None = None, searched=None, disparity: float | None = None,
                  zoom: float | None = None) -> None:
        """`minimum` / `second` as (d, C). `disparity`: the final sub-pixel disparity (vertical
        line). `zoom`: show only ±zoom px around the minimum (None: the whole search range)."""
        x, y = _finite_xy(disparities, criteria)
        self.curve.setData(x, y)
        if searched is not None:
            xs, ys = _finite_xy(disparities, searched)
            self.searched.setData(xs, ys)
            self.searched.show()
            if self.legend.getLabel(self.searched) is None:
                self.legend.addItem(self.searched, "searched (window pre-warped by the marker plane)")
        else:
            self.searched.setData([], [])
            self.searched.hide()
            if self.legend.getLabel(self.searched) is not None:
                self.legend.removeItem(self.searched)
        self._point(self.minimum, minimum)
        self._point(self.second, second)
        if disparity is not None and math.isfinite(disparity):
            self.line.setValue(float(disparity))
            self.line.label.setFormat(f"d* = {disparity:.2f} px")
            self.line.show()
        else:
            self.line.hide()
        if not len(x):
            return
        lo, hi = float(x.min()), float(x.max())
        if zoom is not None and minimum is not None and math.isfinite(minimum[0]):
            lo, hi = max(lo, minimum[0] - zoom), min(hi, minimum[0] + zoom)
        sel = (x >= lo) & (x <= hi)
        ys = y[sel] if sel.any() else y
        # where the window runs off the right image the criteria shoot up by orders of
        # magnitude: scale to the bulk of the curve (those ends leave the plot at the top)
        top = float(np.median(ys)) * 2.5 if len(ys) else 1.0
        for dc in (minimum, second):
            if dc is not None and math.isfinite(dc[1]):
                top = max(top, 1.2 * float(dc[1]))
        self.plot_item.setXRange(lo, hi, padding=0.02)
        # the legend sits in the top right corner: leave it room above the curve
        self.plot_item.setYRange(0.0, max(top, 1.0) * 1.6, padding=0)

    @staticmethod
    def _point(item, dc) -> None:
        if dc is None or not all(math.isfinite(v) for v in dc):
            item.setData([], [])
        else:
            item.setData([float(dc[0])], [float(dc[1])])

    def clear_curve(self) -> None:
        for item in (self.curve, self.searched, self.minimum, self.second):
            item.setData([], [])
        self.line.hide()

    def has_data(self) -> bool:
        x, _ = self.curve.getData()
        return x is not None and len(x) > 0


class WindowSweepPlot(pg.PlotWidget):
    """Minimum criteria versus the window size (Fig. 17)."""

    def __init__(self, parent=None):
        super().__init__(parent=parent, background="w", enableMenu=False)
        self.setObjectName("windowSweepPlot")
        self.plot_item = self.getPlotItem()
        style_plot(self.plot_item, "window size (px, square window)", "minimum criteria (grey level², per pixel)",
                   "Window-size sweep (Fig. 17)")
        self.plot_item.getAxis("left").setWidth(64)
        self.legend = legend(self.plot_item, offset=(10, 10))
        self.legend.anchor((0, 0), (0, 0), offset=(10, 10))
        self.curve = pg.PlotDataItem(pen=pg.mkPen(colour(AXIS, 160), width=1.2))
        self.good = pg.ScatterPlotItem(size=9, brush=colour(GOOD), pen=pg.mkPen("w", width=1))
        self.bad = pg.ScatterPlotItem(size=9, symbol="x", brush=colour(BAD), pen=pg.mkPen(BAD, width=1.5))
        for item in (self.curve, self.good, self.bad):
            self.addItem(item)
        self.legend.addItem(self.good, "minimum at the marker's disparity")
        self.legend.addItem(self.bad, "minimum elsewhere (wrong match)")
        self.sizes = np.zeros(0)
        self.minima = np.zeros(0)

    def set_sweep(self, sizes, minima, disparities=None, located: float | None = None,
                  tolerance: float = 1.0) -> None:
        self.sizes, self.minima = _finite_xy(sizes, minima)
        self.curve.setData(self.sizes, self.minima)
        if disparities is not None and located is not None and math.isfinite(located):
            d = np.asarray(disparities, dtype=float).reshape(-1)
            s_all = np.asarray(sizes, dtype=float).reshape(-1)
            m_all = np.asarray(minima, dtype=float).reshape(-1)
            ok = np.isfinite(s_all) & np.isfinite(m_all)
            at = ok & np.isfinite(d) & (np.abs(d - located) <= tolerance)
            self.good.setData(s_all[at], m_all[at])
            self.bad.setData(s_all[ok & ~at], m_all[ok & ~at])
        else:
            self.good.setData(self.sizes, self.minima)
            self.bad.setData([], [])
        if len(self.sizes):
            self.plot_item.setXRange(float(self.sizes.min()) - 1, float(self.sizes.max()) + 1, padding=0)
            top = float(self.minima.max()) if len(self.minima) else 1.0
            self.plot_item.setYRange(0.0, max(top, 1.0) * 1.4, padding=0)

    def clear_sweep(self) -> None:
        self.curve.setData([], [])
        self.good.setData([], [])
        self.bad.setData([], [])
        self.sizes = self.minima = np.zeros(0)

    def has_data(self) -> bool:
        return len(self.sizes) > 0
