"""3D precision of a verification run: error against the truth and predicted uncertainty
versus the marker's depth.

`set_points(depth, error, sigma)`: per located view, the depth z (mm), the 3D error against
the true position (mm; NaN or None when there is no truth) and the predicted standard
deviation of the 3D point, √(σx² + σy² + σz²) (mm). The predicted σ grows with z² (ΔZ ≈
Z²/(f·b)·Δd), so the plot shows whether the errors follow it.
"""
from __future__ import annotations

import numpy as np
import pyqtgraph as pg

from widgets.plot_theme import AFTER, AXIS, colour, legend, style_plot


class PrecisionPlot(pg.PlotWidget):
    def __init__(self, parent=None):
        super().__init__(parent=parent, background="w")
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
        self.legend.addItem(self.sigmas, "predicted σ of the 3D point")
        self.n_errors = 0
        self.n_sigmas = 0

    def set_points(self, depth, error=None, sigma=None) -> None:
        z = np.asarray(depth, dtype=float).reshape(-1)
        e = np.full_like(z, np.nan) if error is None else np.asarray(error, dtype=float).reshape(-1)
        s = np.full_like(z, np.nan) if sigma is None else np.asarray(sigma, dtype=float).reshape(-1)
        ok_e = np.isfinite(z) & np.isfinite(e)
        ok_s = np.isfinite(z) & np.isfinite(s)
        self.errors.setData(z[ok_e], e[ok_e])
        self.sigmas.setData(z[ok_s], s[ok_s])
        self.n_errors, self.n_sigmas = int(ok_e.sum()), int(ok_s.sum())
        ys = np.concatenate([e[ok_e], s[ok_s]])
        zs = z[ok_e | ok_s]
        if len(zs):
            pad = max(10.0, 0.06 * float(np.ptp(zs)))
            self.plot_item.setXRange(float(zs.min()) - pad, float(zs.max()) + pad, padding=0)
        if len(ys):
            # the legend sits in the top right corner: room above the points
            self.plot_item.setYRange(0.0, max(float(ys.max()), 1e-3) * 1.5, padding=0)

    def clear_points(self) -> None:
        self.set_points(np.zeros(0))
