"""Detection rate and 3D error of the marker against one imaging condition (light, occlusion or
tilt): two stacked plots sharing the condition axis.

`set_rows(values, rate, median, p95, wrong, x_label)`: per condition value the detection rate
and the wrongly accepted share (0 … 1, drawn in %), the median and 95th-percentile 3D error of
the located markers (mm, NaN when none was located).
"""
from __future__ import annotations

import numpy as np
import pyqtgraph as pg

from widgets.plot_theme import AFTER, BEFORE, TEXT, colour, style_plot

WRONG = "#c5221f"


class RobustnessPlot(pg.GraphicsLayoutWidget):
    def __init__(self, parent=None):
        super().__init__(parent=parent)
        self.setObjectName("robustnessPlot")
        self.setBackground("w")
        # one legend above both plots, in its own row, so it never hides a curve
        self.legend = pg.LegendItem(offset=None, labelTextColor=TEXT, labelTextSize="8.5pt", colCount=2)
        self.addItem(self.legend, row=0, col=0)
        self.rate_plot = self.addPlot(row=1, col=0, enableMenu=False)
        self.error_plot = self.addPlot(row=2, col=0, enableMenu=False)
        self.error_plot.setXLink(self.rate_plot)
        # styled once: styling again would keep a stale SI-prefix scale on the axes
        style_plot(self.rate_plot, "", "detected (%)", "Marker detection")
        style_plot(self.error_plot, "condition", "3D error (mm)")
        for p in (self.rate_plot, self.error_plot):
            p.getAxis("left").setWidth(60)
        self.rate = self.rate_plot.plot(pen=pg.mkPen(AFTER, width=2), symbol="o", symbolSize=7,
                                        symbolBrush=colour(AFTER))
        self.wrong = self.rate_plot.plot(pen=pg.mkPen(WRONG, width=1.5, style=pg.QtCore.Qt.PenStyle.DashLine),
                                         symbol="x", symbolSize=8, symbolPen=pg.mkPen(WRONG), symbolBrush=None)
        self.median = self.error_plot.plot(pen=pg.mkPen(AFTER, width=2), symbol="o", symbolSize=7,
                                           symbolBrush=colour(AFTER))
        self.p95 = self.error_plot.plot(pen=pg.mkPen(BEFORE, width=1.5), symbol="t", symbolSize=7,
                                        symbolBrush=colour(BEFORE))
        self.legend.addItem(self.rate, "detection rate")
        self.legend.addItem(self.wrong, "accepted > 2 mm off (wrong)")
        self.legend.addItem(self.median, "median 3D error")
        self.legend.addItem(self.p95, "95th percentile 3D error")
        self.set_rows([], [], [], [], [], "condition")

    def set_rows(self, values, rate, median, p95, wrong, x_label: str) -> None:
        x = np.asarray(values, dtype=float)
        self.rate_plot.setTitle(f"Marker detection vs {x_label}", color=TEXT, size="9.5pt")
        self.error_plot.setLabel("bottom", x_label, color=TEXT, size="9pt")
        self.rate.setData(x, 100.0 * np.asarray(rate, dtype=float))
        self.wrong.setData(x, 100.0 * np.asarray(wrong, dtype=float))
        m, q = np.asarray(median, dtype=float), np.asarray(p95, dtype=float)
        ok = np.isfinite(m)
        self.median.setData(x[ok], m[ok])
        self.p95.setData(x[ok], q[ok])
        self.rate_plot.setYRange(0.0, 110.0, padding=0)
        if len(x):
            pad = 0.05 * max(float(np.ptp(x)), 1e-6)
            self.rate_plot.setXRange(float(x.min()) - pad, float(x.max()) + pad, padding=0)
        top = float(np.nanmax(q)) if ok.any() else 0.1
        self.error_plot.setYRange(0.0, max(top, 1e-3) * 1.1, padding=0)
