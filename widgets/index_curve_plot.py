"""An observability index versus the number of poses: the selected sets beside random ones.

`set_curve(n, selected, random_median, random_q25, random_q75, count=N, y_label=..., log_y=...)`
draws the index of the selected (nested) sets as a blue line with dots, the median of random
selections of each size as an orange dashed line with its 25–75 % band, and marks the chosen
N with a vertical line and a larger dot. Non-finite values (a rank-deficient set) are left out.
"""
from __future__ import annotations

import math

import numpy as np
import pyqtgraph as pg
from PySide6.QtCore import Qt

from widgets.plot_theme import AFTER, AXIS, BEFORE, TEXT, colour, legend, readable_axes, style_plot


class IndexCurvePlot(pg.PlotWidget):
    def __init__(self, parent=None):
        super().__init__(parent=parent, background="w", axisItems=readable_axes(), enableMenu=False)
        self.setObjectName("indexCurvePlot")
        self.plot_item = self.getPlotItem()
        style_plot(self.plot_item, "number of poses N", "index")
        self.legend = legend(self.plot_item)
        self.band_low = pg.PlotDataItem(pen=pg.mkPen(None))
        self.band_high = pg.PlotDataItem(pen=pg.mkPen(None))
        self.band = pg.FillBetweenItem(self.band_low, self.band_high, brush=pg.mkBrush(colour(BEFORE, 45)))
        self.random_curve = pg.PlotDataItem(pen=pg.mkPen(BEFORE, width=2, style=Qt.PenStyle.DashLine),
                                            name="random selections: median")
        self.selected_curve = pg.PlotDataItem(pen=pg.mkPen(AFTER, width=2), symbol="o", symbolSize=5,
                                              symbolBrush=AFTER, symbolPen=pg.mkPen(AFTER),
                                              name="selected poses")
        self.chosen_point = pg.PlotDataItem(pen=None, symbol="o", symbolSize=12, symbolBrush=colour(AFTER),
                                            symbolPen=pg.mkPen("w", width=1.5))
        self.chosen_line = pg.InfiniteLine(angle=90, pen=pg.mkPen(AXIS, style=Qt.PenStyle.DotLine))
        for item in (self.band_low, self.band_high, self.band, self.random_curve, self.selected_curve,
                     self.chosen_point):
            self.addItem(item)
        self.addItem(self.chosen_line)
        # the legend cannot draw a FillBetweenItem: a wide translucent line stands for the band (an
        # empty line inside the legend, so it lives and ends with the plot's scene)
        self._band_proxy = pg.PlotDataItem(pen=pg.mkPen(colour(BEFORE, 70), width=9))
        self._band_proxy.setParentItem(self.legend)
        self.legend.addItem(self._band_proxy, "random: 25–75 %")
        self.legend.addItem(self.chosen_point, "the selection")
        self.chosen_line.hide()
        self.n = np.zeros(0)
        self.selected = np.zeros(0)
        self.random_median = np.zeros(0)
        self.log_y = False

    def set_curve(self, n, selected, random_median, random_q25=None, random_q75=None, *, count: int | None = None,
                  y_label: str = "index", log_y: bool = False, random_label: str = "random selections: median",
                  selected_label: str = "selected poses", legend_corner: str = "right") -> None:
        """`legend_corner`: "right" (top right, for falling curves) or "left" (top left, for rising ones)."""
        self.n = np.asarray(n, dtype=float).reshape(-1)
        self.selected = np.asarray(selected, dtype=float).reshape(-1)
        self.random_median = np.asarray(random_median, dtype=float).reshape(-1)
        self.log_y = bool(log_y)
        self.plot_item.setLogMode(y=self.log_y)
        self.plot_item.setLabel("left", y_label, color=TEXT, size="9pt")
        if legend_corner == "left":
            self.legend.anchor((0, 0), (0, 0), offset=(10, 10))
        else:
            self.legend.anchor((1, 0), (1, 0), offset=(-10, 10))
        self.legend.getLabel(self.random_curve).setText(random_label)
        self.legend.getLabel(self.selected_curve).setText(selected_label)

        def finite(y):
            ok = np.isfinite(y) & ((y > 0) if self.log_y else True)
            return self.n[ok], y[ok]

        self.selected_curve.setData(*finite(self.selected))
        self.random_curve.setData(*finite(self.random_median))
        if random_q25 is not None and random_q75 is not None:
            lo = np.asarray(random_q25, dtype=float).reshape(-1)
            hi = np.asarray(random_q75, dtype=float).reshape(-1)
            ok = np.isfinite(lo) & np.isfinite(hi) & (((lo > 0) & (hi > 0)) if self.log_y else True)
            self.band_low.setData(self.n[ok], lo[ok])
            self.band_high.setData(self.n[ok], hi[ok])
            self.band.show()
        else:
            self.band_low.setData([], [])
            self.band_high.setData([], [])
            self.band.hide()
        if count is not None and np.any(self.n == count):
            k = int(np.flatnonzero(self.n == count)[0])
            y = self.selected[k]
            if math.isfinite(y) and (y > 0 or not self.log_y):
                self.chosen_point.setData([count], [y])
            self.chosen_line.setValue(count)
            self.chosen_line.show()
            self.legend.getLabel(self.chosen_point).setText(f"the selection, N = {count}")
        else:
            self.chosen_point.setData([], [])
            self.chosen_line.hide()
        self._fit_range()

    def _fit_range(self) -> None:
        if not len(self.n):
            return
        self.setXRange(float(self.n.min()) - 0.5, float(self.n.max()) + 0.5, padding=0)
        ys = np.concatenate([self.selected, self.random_median])
        ys = ys[np.isfinite(ys) & ((ys > 0) if self.log_y else True)]
        if not len(ys):
            return
        if self.log_y:
            ly = np.log10(ys)
            span = max(float(ly.max() - ly.min()), 0.3)
            # the top leaves room for the legend
            self.setYRange(float(ly.min()) - 0.06 * span, float(ly.max()) + 0.45 * span, padding=0)
        else:
            lo, hi = float(min(ys.min(), 0.0)), float(ys.max())
            span = max(hi - lo, 1e-12)
            self.setYRange(lo, hi + 0.45 * span, padding=0)

    def clear_curve(self) -> None:
        for item in (self.selected_curve, self.random_curve, self.chosen_point, self.band_low, self.band_high):
            item.setData([], [])
        self.chosen_line.hide()
        self.n = self.selected = self.random_median = np.zeros(0)

    def has_data(self) -> bool:
        return len(self.selected_curve.getData()[0] if self.selected_curve.getData()[0] is not None else []) > 0
