"""3D precision of a verification run: error against the truth and predicted uncertainty
versus the marker's depth.

`set_points(depth, error, sigma)`: per located view, the depth z (mm), the 3D error against
the true position (mm; NaN or None when there is no truth) and the predicted standard
deviation of the 3D point, √(σx² + σy² + σz²) (mm), from the image noise; `total_sigma`,
when known, the σ with the stereo calibration's own uncertainty added (mm). The predicted σ
grows with z² (ΔZ ≈ Z²/(f·b)·Δd), so the plot shows whether the errors follow it.
"""
from __future__ import annotations

import numpy as np
import pyqtgraph as pg

from widgets.plot_theme import AFTER, AXIS, colour, legend, style_plot


class PrecisionPlot(pg.PlotWidget):
    def __init__(self, parent=None):
        super().__init__(parent=parent, background="w", enableMenu=False)
        self.setObjectName("precisionPlot")
        self.plot_item = self.getPlotItem()
        style_plot(self.plot_item, "marker depth z (mm)", "3D distance (mm)", "Precision of the located points")
        self.legend = legend(self.plot_item)
        self.plot_item.getAxis("left").setWidth(64)     # room for the ticks and the label from the start
        self.errors = pg.ScatterPlotItem(size=8, brush=colour(AFTER, 210), pen=pg.mkPen("w", width=0.8))
        self.sigmas = pg.ScatterPlotItem(size=8, symbol="t1", brush=colour(AXIS, 140), pen=None)
        self.addItem(self.sigmas)
        self.addItem(self.errors)
        self.legend.addItem(self.errors, "error against the true position")
        self.legend.addItem(self.sigmas, "predicted σ of the 3D point (image noise)")
        self.totals = pg.ScatterPlotItem(size=9, symbol="t", brush=None, pen=pg.mkPen(colour(AXIS, 230), width=1.3))
        self.addItem(self.totals)
        self.n_errors = 0
        self.n_sigmas = 0
        self.n_totals = 0

    def set_points(self, depth, error=None, sigma=None, total_sigma=None) -> None:
        z = np.asarray(depth, dtype=float).reshape(-1)

        def values(v):
            return np.full_like(z, np.nan) if v is None else np.asarray(v, dtype=float).reshape(-1)

        e, s, t = values(error), values(sigma), values(total_sigma)
        ok_e = np.isfinite(z) & np.isfinite(e)
        ok_s = np.isfinite(z) & np.isfinite(s)
        ok_t = np.isfinite(z) & np.isfinite(t)
        self.errors.setData(z[ok_e], e[ok_e])
        self.sigmas.setData(z[ok_s], s[ok_s])
        self.totals.setData(z[ok_t], t[ok_t])
        had = self.n_totals > 0
        self.n_errors, self.n_sigmas, self.n_totals = int(ok_e.sum()), int(ok_s.sum()), int(ok_t.sum())
        if self.n_totals and not had:
            self.legend.addItem(self.totals, "σ with the stereo calibration's uncertainty")
        elif had and not self.n_totals:
            self.legend.removeItem(self.totals)
        ys = np.concatenate([e[ok_e], s[ok_s], t[ok_t]])
        zs = z[ok_e | ok_s | ok_t]
        if len(zs):
            pad = max(10.0, 0.06 * float(np.ptp(zs)))
            self.plot_item.setXRange(float(zs.min()) - pad, float(zs.max()) + pad, padding=0)
        if len(ys):
            # the legend sits in the top right corner: room above the points
            self.plot_item.setYRange(0.0, max(float(ys.max()), 1e-3) * 1.5, padding=0)

    def clear_points(self) -> None:
        self.set_points(np.zeros(0))
