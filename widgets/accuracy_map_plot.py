"""The before/after accuracy map: error vectors over the robot base XY plane and a histogram of
the error lengths, nominal model (orange) against calibrated model (blue), with the factor of
improvement in the title.

`set_map(amap)` with a core.compensation.accuracy_map.AccuracyMap (None clears). Vectors are
magnified by one factor for both models (shown in the legend), so the calibrated model's short
arrows look as short as they are; the histogram's length axis is logarithmic, so both models'
errors are readable side by side.
"""
from __future__ import annotations

import numpy as np
import pyqtgraph as pg
from PySide6.QtWidgets import QHBoxLayout, QWidget

from widgets.plot_theme import AFTER, BEFORE, TEXT, colour, legend, readable_axes, style_plot

TARGET = "#5f6368"
ARROW_SHARE = 0.3           # the longest arrow is this share of the map's extent
BINS_PER_DECADE = 5


def _arrows(start: np.ndarray, vectors: np.ndarray, scale: float) -> tuple[np.ndarray, np.ndarray]:
    """x, y of line pairs (start, start + scale·vector) for connect="pairs"."""
    ok = np.all(np.isfinite(vectors), axis=1)
    a, b = start[ok], start[ok] + scale * vectors[ok]
    xy = np.empty((2 * len(a), 2))
    xy[0::2], xy[1::2] = a, b
    return xy[:, 0], xy[:, 1]


def _magnification(span: float, longest: float) -> float:
    """A round factor (1, 2, 5 × 10^k) that makes the longest arrow about ARROW_SHARE of `span`."""
    if not longest > 0:
        return 1.0
    raw = ARROW_SHARE * span / longest
    k = 10.0 ** np.floor(np.log10(raw))
    return float(max(m * k for m in (1, 2, 5) if m * k <= raw))


class AccuracyMapPlot(QWidget):
    """Two plots side by side: error vectors (XY, mm) and the histogram of error lengths (mm)."""

    def __init__(self, parent=None):
        super().__init__(parent)
        self.setObjectName("accuracyMapPlot")
        self.vectors = pg.PlotWidget(background="w", enableMenu=False)
        vec = self.vectors.getPlotItem()
        style_plot(vec, "x in the robot base frame (mm)", "y in the robot base frame (mm)", "Error vectors")
        vec.setAspectLocked(True, ratio=1.0)
        self.targets = pg.ScatterPlotItem(size=6, pen=pg.mkPen(TARGET), brush=None, symbol="o")
        self.before_lines = pg.PlotDataItem(pen=pg.mkPen(BEFORE, width=2), connect="pairs")
        self.after_lines = pg.PlotDataItem(pen=pg.mkPen(AFTER, width=2), connect="pairs")
        self.before_tips = pg.ScatterPlotItem(size=5, pen=None, brush=colour(BEFORE))
        self.after_tips = pg.ScatterPlotItem(size=5, pen=None, brush=colour(AFTER))
        for item in (self.targets, self.before_lines, self.after_lines, self.before_tips, self.after_tips):
            vec.addItem(item)
        self.vector_legend = legend(vec)

        self.histogram = pg.PlotWidget(background="w", axisItems=readable_axes(), enableMenu=False)
        hist = self.histogram.getPlotItem()
        style_plot(hist, "position error (mm, logarithmic)", "targets", "Error lengths")
        hist.setLogMode(x=True, y=False)
        self.before_hist = pg.PlotDataItem(stepMode="center", fillLevel=0, pen=pg.mkPen(BEFORE, width=1.5),
                                           brush=colour(BEFORE, 110))
        self.after_hist = pg.PlotDataItem(stepMode="center", fillLevel=0, pen=pg.mkPen(AFTER, width=1.5),
                                          brush=colour(AFTER, 110))
        hist.addItem(self.before_hist)
        hist.addItem(self.after_hist)
        self.hist_legend = legend(hist)

        layout = QHBoxLayout(self)
        layout.setContentsMargins(0, 0, 0, 0)
        layout.addWidget(self.vectors, 3)
        layout.addWidget(self.histogram, 2)
        for plot in (self.vectors, self.histogram):
            plot.setMinimumWidth(180)
        self.magnification = 1.0
        self.set_map(None)

    def set_map(self, amap) -> None:
        """Draw `amap` (an AccuracyMap), or nothing (None)."""
        vec, hist = self.vectors.getPlotItem(), self.histogram.getPlotItem()
        self.vector_legend.clear()
        self.hist_legend.clear()
        if amap is None or not amap.both.any():
            for item in (self.targets, self.before_tips, self.after_tips):
                item.setData([], [])
            for item in (self.before_lines, self.after_lines, self.before_hist, self.after_hist):
                item.setData([], [])
            vec.setTitle("Error vectors (no accuracy map yet)", color=TEXT, size="9.5pt")
            hist.setTitle("Error lengths", color=TEXT, size="9.5pt")
            return
        both = amap.both
        xy = amap.targets_base[both, :2]
        before, after = amap.vectors_before[both, :2], amap.vectors_after[both, :2]
        span = float(np.ptp(xy, axis=0).max()) if len(xy) > 1 else 100.0
        longest = float(np.linalg.norm(before, axis=1).max())
        self.magnification = m = _magnification(max(span, 50.0), longest)
        self.targets.setData(xy[:, 0], xy[:, 1])
        self.before_lines.setData(*_arrows(xy, before, m))
        self.after_lines.setData(*_arrows(xy, after, m))
        self.before_tips.setData(*(xy + m * before).T)
        self.after_tips.setData(*(xy + m * after).T)
        self.vector_legend.addItem(self.targets, "target")
        self.vector_legend.addItem(self.before_lines, f"nominal model, error ×{m:g}")
        self.vector_legend.addItem(self.after_lines, f"calibrated model, error ×{m:g}")
        vec.setTitle(f"Error vectors in the base XY plane: {amap.improvement:.0f}× more accurate",
                     color=TEXT, size="9.5pt")
        vec.autoRange()

        eb, ea = amap.errors_before, amap.errors_after
        positive = np.concatenate([eb, ea])
        positive = positive[positive > 0]
        lo = np.floor(np.log10(positive.min()) * BINS_PER_DECADE) / BINS_PER_DECADE
        hi = np.ceil(np.log10(positive.max()) * BINS_PER_DECADE) / BINS_PER_DECADE + 1.0 / BINS_PER_DECADE
        edges = 10.0 ** np.arange(lo, hi + 1e-9, 1.0 / BINS_PER_DECADE)
        counts_b, _ = np.histogram(eb, edges)
        counts_a, _ = np.histogram(ea, edges)
        self.before_hist.setData(edges, counts_b)
        self.after_hist.setData(edges, counts_a)
        self.hist_legend.addItem(self.before_hist, f"nominal: RMS {amap.rms_before_mm:.2f} mm")
        self.hist_legend.addItem(self.after_hist, f"calibrated: RMS {amap.rms_after_mm:.3f} mm")
        hist.setTitle(f"Error lengths, {int(both.sum())} targets", color=TEXT, size="9.5pt")
        hist.setYRange(0, max(counts_b.max(), counts_a.max()) * 1.45, padding=0)
        hist.setXRange(lo, hi, padding=0.02)
