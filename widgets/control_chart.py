"""A control chart: one error per check (mm) over the check number, its limit drawn as a
dashed step line, the points beyond their limit marked red.

`set_series(checks, errors, limits)`: check numbers (1, 2, …), errors (mm) and each check's
limit (mm; the limit may change after a re-identification)."""
from __future__ import annotations

import numpy as np
import pyqtgraph as pg
from PySide6.QtCore import Qt

from widgets.plot_theme import AFTER, BEFORE, legend, style_plot

OUT = "#d93025"     # red: beyond the limit


class ControlChart(pg.PlotWidget):
    def __init__(self, title: str = "", parent=None, *, with_legend: bool = True, y_label: str = "error (mm)"):
        super().__init__(parent=parent, background="w", enableMenu=False)
        self.setObjectName("controlChart")
        plot = self.getPlotItem()
        style_plot(plot, "check number", y_label, title or None)
        if with_legend:
            legend(plot)
        self.curve = pg.PlotDataItem(pen=pg.mkPen(AFTER, width=1.5), symbol="o", symbolSize=6,
                                     symbolBrush=AFTER, symbolPen=pg.mkPen("w"), name="error")
        self.limit = pg.PlotDataItem(pen=pg.mkPen(BEFORE, width=1.5, style=Qt.PenStyle.DashLine),
                                     stepMode="center", name="limit")
        self.beyond = pg.ScatterPlotItem(symbol="x", size=11, pen=pg.mkPen(OUT, width=2.5), brush=pg.mkBrush(OUT),
                                         name="beyond the limit")
        for item in (self.limit, self.curve, self.beyond):
            self.addItem(item)
        self.x = np.zeros(0)
        self.y = np.zeros(0)
        self.limits = np.zeros(0)

    @property
    def beyond_count(self) -> int:
        return int(np.sum(self.y > self.limits))

    def set_series(self, checks, errors, limits) -> None:
        self.x = np.asarray(checks, dtype=float).reshape(-1)
        self.y = np.asarray(errors, dtype=float).reshape(-1)
        self.limits = np.broadcast_to(np.asarray(limits, dtype=float), self.y.shape).copy()
        self.curve.setData(self.x, self.y)
        if len(self.x):
            edges = np.concatenate([self.x - 0.5, [self.x[-1] + 0.5]])
            self.limit.setData(edges, self.limits)
        else:
            self.limit.setData([], [])
        out = self.y > self.limits
        self.beyond.setData(self.x[out], self.y[out])
        if len(self.x):
            top = float(max(self.y.max(), self.limits.max()))
            lo, hi = float(self.x.min()), max(float(self.x.max()), float(self.x.min()) + 4)
            step = max(1, int(np.ceil((hi - lo + 1) / 10)))          # whole check numbers, at most ~10 labels
            self.getPlotItem().getAxis("bottom").setTickSpacing(major=step, minor=step)
            self.setXRange(lo - 0.6, hi + 0.6, padding=0)
            self.setYRange(0.0, 1.12 * top if top > 0 else 1.0, padding=0)
