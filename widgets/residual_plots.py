"""Position errors before and after a calibration: per pose (bar chart) and their histogram.

Both plots take plain arrays in mm; they know nothing of where the errors come from. Errors
before and after calibration usually differ by one or two orders of magnitude, so the error
axis is logarithmic by default (`set_log(False)` for a linear one).
"""
from __future__ import annotations

import math

import numpy as np
import pyqtgraph as pg
from PySide6.QtCore import Qt, Signal
from PySide6.QtWidgets import QCheckBox, QHBoxLayout, QLabel, QSplitter, QVBoxLayout, QWidget

from widgets.plot_theme import AFTER, BEFORE, colour, legend, readable_axes, style_plot

FLOOR_MM = 1e-6        # errors are clipped here for the logarithmic axis
BEFORE_LABEL = "before (nominal model)"
AFTER_LABEL = "after (calibrated model)"


def _log_floor(values: np.ndarray) -> float:
    """A decade below the smallest positive value: where log bars start."""
    pos = values[values > 0]
    if len(pos) == 0:
        return math.log10(FLOOR_MM)
    return math.floor(math.log10(max(float(pos.min()), FLOOR_MM)))


class ResidualBarChart(pg.PlotWidget):
    """Error of every pose before (orange) and after (blue) calibration, side by side."""

    def __init__(self, parent=None):
        super().__init__(parent=parent, background="w", axisItems=readable_axes(), enableMenu=False)
        style_plot(self.getPlotItem(), "pose", "position error (mm)")
        self.setObjectName("residualBarChart")
        self._log = True
        self._x = np.zeros(0)
        self._before = np.zeros(0)
        self._after = np.zeros(0)
        pen = pg.mkPen(None)
        self.before_bars = pg.BarGraphItem(x=[], height=[], width=0.4, pen=pen, brush=colour(BEFORE))
        self.after_bars = pg.BarGraphItem(x=[], height=[], width=0.4, pen=pen, brush=colour(AFTER))
        self.legend = legend(self.getPlotItem())
        self.addItem(self.before_bars)
        self.addItem(self.after_bars)
        self.legend.addItem(self.before_bars, BEFORE_LABEL)
        self.legend.addItem(self.after_bars, AFTER_LABEL)
        self.getPlotItem().setLogMode(y=True)

    def set_errors(self, pose_ids, before, after) -> None:
        """One value per pose (mm); `before` or `after` may be None."""
        self._x = np.asarray(pose_ids, dtype=float).reshape(-1)
        n = len(self._x)
        self._before = np.zeros(0) if before is None else np.asarray(before, dtype=float).reshape(-1)
        self._after = np.zeros(0) if after is None else np.asarray(after, dtype=float).reshape(-1)
        if len(self._before) not in (0, n) or len(self._after) not in (0, n):
            raise ValueError("one error per pose expected")
        self._redraw()

    def clear_errors(self) -> None:
        self.set_errors([], None, None)

    def set_log(self, log: bool) -> None:
        self._log = bool(log)
        self.getPlotItem().setLogMode(y=self._log)
        self._redraw()

    @property
    def log(self) -> bool:
        return self._log

    def series(self) -> dict[str, np.ndarray]:
        """What is drawn (mm, not logarithms): {"pose", "before", "after"} (tests)."""
        return {"pose": self._x.copy(), "before": self._before.copy(), "after": self._after.copy()}

    def _redraw(self) -> None:
        both = np.concatenate([self._before, self._after])
        floor = _log_floor(both) if self._log else 0.0
        for bars, values, shift in ((self.before_bars, self._before, -0.2), (self.after_bars, self._after, 0.2)):
            if len(values) == 0:
                bars.setOpts(x=[], height=[], y0=0)
                continue
            values = np.where(np.isfinite(values), values, 0.0)
            if self._log:
                top = np.log10(np.maximum(values, 10.0 ** floor))
                bars.setOpts(x=self._x + shift, y0=np.full(len(values), floor), height=top - floor)
            else:
                bars.setOpts(x=self._x + shift, y0=np.zeros(len(values)), height=values)
        if len(self._x):
            self.setXRange(float(self._x.min()) - 0.8, float(self._x.max()) + 0.8, padding=0)
            if len(both):
                # headroom above the bars for the legend
                if self._log:
                    top = math.log10(max(float(np.nanmax(both)), 10.0 ** floor))
                    self.setYRange(floor, top + 0.25 + 0.45 * (top - floor), padding=0)
                else:
                    self.setYRange(0.0, float(np.nanmax(both)) * 1.45 or 1.0, padding=0)
        else:
            self.enableAutoRange()


class ResidualHistogram(pg.PlotWidget):
    """How many points have which error, before and after calibration (same bins)."""

    def __init__(self, parent=None):
        super().__init__(parent=parent, background="w", axisItems=readable_axes(), enableMenu=False)
        style_plot(self.getPlotItem(), "position error (mm)", "points")
        self.setObjectName("residualHistogram")
        self._log = True
        self._before = np.zeros(0)
        self._after = np.zeros(0)
        self.edges = np.zeros(0)
        self.counts: dict[str, np.ndarray] = {"before": np.zeros(0), "after": np.zeros(0)}
        self.before_curve = pg.PlotDataItem(stepMode="center", fillLevel=0, pen=pg.mkPen(BEFORE, width=1.5),
                                            brush=colour(BEFORE, 110))
        self.after_curve = pg.PlotDataItem(stepMode="center", fillLevel=0, pen=pg.mkPen(AFTER, width=1.5),
                                           brush=colour(AFTER, 110))
        self.legend = legend(self.getPlotItem())
        self.addItem(self.before_curve)
        self.addItem(self.after_curve)
        self.legend.addItem(self.before_curve, BEFORE_LABEL)
        self.legend.addItem(self.after_curve, AFTER_LABEL)
        self.getPlotItem().setLogMode(x=True)

    def set_errors(self, before, after) -> None:
        """Errors of every point (mm); `before` or `after` may be None."""
        self._before = np.zeros(0) if before is None else np.asarray(before, dtype=float).reshape(-1)
        self._after = np.zeros(0) if after is None else np.asarray(after, dtype=float).reshape(-1)
        self._redraw()

    def clear_errors(self) -> None:
        self.set_errors(None, None)

    def set_log(self, log: bool) -> None:
        self._log = bool(log)
        self.getPlotItem().setLogMode(x=self._log)
        self._redraw()

    def _redraw(self) -> None:
        both = np.concatenate([self._before, self._after])
        both = both[np.isfinite(both)]
        if len(both) == 0:
            self.edges = np.zeros(0)
            self.counts = {"before": np.zeros(0), "after": np.zeros(0)}
            for curve in (self.before_curve, self.after_curve):
                curve.setData([], [])
            return
        n_bins = int(np.clip(round(2.0 * math.sqrt(len(both))), 8, 40))
        if self._log:
            lo = math.log10(max(float(both.min()), FLOOR_MM))
            hi = math.log10(max(float(both.max()), FLOOR_MM))
            if hi - lo < 1e-9:
                lo, hi = lo - 0.5, hi + 0.5
            edges = 10.0 ** np.linspace(lo - 0.02, hi + 0.02, n_bins + 1)
        else:
            hi = float(both.max()) or 1.0
            edges = np.linspace(0.0, hi * 1.02, n_bins + 1)
        self.edges = edges
        top = 0
        for key, values, curve in (("before", self._before, self.before_curve),
                                   ("after", self._after, self.after_curve)):
            if len(values) == 0:
                self.counts[key] = np.zeros(0)
                curve.setData([], [])
                continue
            counts, _ = np.histogram(np.clip(values, edges[0], edges[-1]), bins=edges)
            self.counts[key] = counts
            top = max(top, int(counts.max()))
            curve.setData(edges, counts.astype(float))
        self.setYRange(0, top * 1.6 + 0.5, padding=0)     # headroom for the legend
        if self._log:
            self.setXRange(math.log10(edges[0]), math.log10(edges[-1]), padding=0.02)
        else:
            self.setXRange(edges[0], edges[-1], padding=0.02)


class ResidualPlots(QWidget):
    """The bar chart beside the histogram, with one switch for the logarithmic error axis."""

    logChanged = Signal(bool)

    def __init__(self, parent=None):
        super().__init__(parent)
        self.bars = ResidualBarChart()
        self.histogram = ResidualHistogram()
        self.log_box = QCheckBox("Logarithmic error axis")
        self.log_box.setChecked(True)
        self.log_box.setToolTip("Errors before and after calibration often differ by a factor of 10–100: "
                                "on a logarithmic axis both stay readable.")
        self.log_box.toggled.connect(self.set_log)
        self.caption = QLabel()
        self.caption.setObjectName("hint")
        self.caption.setWordWrap(True)
        top = QHBoxLayout()
        top.addWidget(self.caption, 1)
        top.addWidget(self.log_box)
        layout = QVBoxLayout(self)
        layout.setContentsMargins(0, 0, 0, 0)
        layout.addLayout(top)
        self.splitter = QSplitter(Qt.Orientation.Horizontal)
        self.splitter.addWidget(self.bars)
        self.splitter.addWidget(self.histogram)
        self.splitter.setStretchFactor(0, 3)
        self.splitter.setStretchFactor(1, 2)
        self.splitter.setChildrenCollapsible(False)
        layout.addWidget(self.splitter, 1)

    def set_log(self, log: bool) -> None:
        if self.log_box.isChecked() != bool(log):
            self.log_box.setChecked(bool(log))       # calls back here
            return
        self.bars.set_log(log)
        self.histogram.set_log(log)
        self.logChanged.emit(bool(log))

    def set_errors(self, pose_ids, pose_before, pose_after, point_before, point_after, caption: str = "") -> None:
        self.bars.set_errors(pose_ids, pose_before, pose_after)
        self.histogram.set_errors(point_before, point_after)
        self.caption.setText(caption)

    def clear(self) -> None:
        self.bars.clear_errors()
        self.histogram.clear_errors()
        self.caption.setText("")
