"""Reprojection error per stereo pair (left and right bars side by side) with a draggable
threshold line, as MATLAB's Stereo Camera Calibrator: pairs with a bar above the line are
selected (drawn in red) for removal. Pairs flagged automatically are marked with a red
triangle above their bars, and the automatic threshold is a dashed line.

`set_errors(pairs, left, right, flagged=None, auto_threshold=None)` with one value per pair
(px); `threshold()` / `set_threshold(v)`; `selected()` gives the row numbers of the pairs
above the line; signal `selectionChanged(list)`. The caller decides what a pair number is.
"""
from __future__ import annotations

from typing import Sequence

import numpy as np
import pyqtgraph as pg
from PySide6.QtCore import Signal

from widgets.plot_theme import AXIS, TEXT, colour, style_plot

LEFT = "#1a73e8"
RIGHT = "#e37400"
SELECTED_LEFT = "#d93025"
SELECTED_RIGHT = "#a50e0e"
FLAG = "#c5221f"
LINE = "#202124"
WIDTH = 0.38


class ErrorBarChart(pg.GraphicsLayoutWidget):
    """The legend sits in its own row above the plot, so it never hides a bar."""

    selectionChanged = Signal(list)

    def __init__(self, parent=None, *, x_label: str = "pair", y_label: str = "RMS reprojection error (px)",
                 names: tuple[str, str] = ("left camera", "right camera")):
        super().__init__(parent=parent)
        self.setBackground("w")
        self.setObjectName("errorBarChart")
        self.ci.setContentsMargins(2, 2, 2, 2)
        self.ci.setSpacing(0)
        self.legend = pg.LegendItem(colCount=4, labelTextColor=TEXT, labelTextSize="8.5pt",
                                    horSpacing=14, verSpacing=-4)
        self.addItem(self.legend, row=0, col=0)
        self.plot = plot = self.addPlot(row=1, col=0, enableMenu=False)
        self.ci.layout.setRowStretchFactor(1, 1)
        style_plot(plot, x_label, y_label)
        plot.setMouseEnabled(x=False, y=False)
        self._pairs = np.zeros(0)
        self._left = np.zeros(0)
        self._right = np.zeros(0)
        self._flagged = np.zeros(0, bool)
        self._selected: list[int] = []
        pen = pg.mkPen(None)
        self.left_bars = pg.BarGraphItem(x=[], height=[], width=WIDTH, pen=pen, brush=colour(LEFT))
        self.right_bars = pg.BarGraphItem(x=[], height=[], width=WIDTH, pen=pen, brush=colour(RIGHT))
        self.flags = pg.ScatterPlotItem(symbol="t", size=11, pen=pg.mkPen(FLAG), brush=colour(FLAG))
        # a legend entry for the selection colour (never drawn with data; inside the legend, so it
        # lives and ends with the plot's scene)
        self._selected_key = pg.BarGraphItem(x=[], height=[], width=WIDTH, pen=pen, brush=colour(SELECTED_LEFT))
        self._selected_key.setParentItem(self.legend)
        self.auto_line = pg.InfiniteLine(angle=0, movable=False,
                                         pen=pg.mkPen(AXIS, width=1, style=pg.QtCore.Qt.PenStyle.DashLine),
                                         label="automatic outlier threshold {value:.3f} px",
                                         labelOpts={"position": 0.01, "color": AXIS, "anchors": [(0, 0), (0, 0)]})
        self.line = pg.InfiniteLine(angle=0, movable=True, pen=pg.mkPen(LINE, width=2),
                                    hoverPen=pg.mkPen(SELECTED_LEFT, width=3),
                                    label="⇕ drag: drop pairs above {value:.3f} px",
                                    labelOpts={"position": 0.01, "color": TEXT, "anchors": [(0, 1), (0, 1)],
                                               "fill": (255, 255, 255, 200)})
        self.line.setZValue(20)
        self.auto_line.setZValue(5)
        for item in (self.left_bars, self.right_bars, self.flags, self.auto_line, self.line):
            plot.addItem(item)
        self.legend.addItem(self.left_bars, names[0])
        self.legend.addItem(self.right_bars, names[1])
        self.legend.addItem(self._selected_key, "above the line: to drop")
        self.legend.addItem(self.flags, "flagged as outlier")
        self.line.sigPositionChanged.connect(self._line_moved)
        self.auto_line.hide()
        self.line.hide()

    def getPlotItem(self) -> pg.PlotItem:
        return self.plot

    # -- data -----------------------------------------------------------------------------
    def set_errors(self, pairs: Sequence[float], left: Sequence[float], right: Sequence[float],
                   flagged: Sequence[bool] | None = None, auto_threshold: float | None = None,
                   threshold: float | None = None) -> None:
        """One value per pair (px). The threshold starts above every bar (nothing selected)
        unless `threshold` is given."""
        self._pairs = np.asarray(pairs, dtype=float).reshape(-1)
        n = len(self._pairs)
        self._left = np.asarray(left, dtype=float).reshape(-1)
        self._right = np.asarray(right, dtype=float).reshape(-1)
        self._flagged = (np.zeros(n, bool) if flagged is None else np.asarray(flagged, dtype=bool).reshape(-1))
        if len(self._left) != n or len(self._right) != n or len(self._flagged) != n:
            raise ValueError("one value per pair expected")
        top = float(np.nanmax(np.concatenate([self._left, self._right]))) if n else 1.0
        if auto_threshold is not None and np.isfinite(auto_threshold):
            top = max(top, float(auto_threshold))
        top = top if top > 0 else 1.0
        plot = self.getPlotItem()
        if n:
            plot.setXRange(float(self._pairs.min()) - 0.7, float(self._pairs.max()) + 0.7, padding=0)
            plot.setYRange(0.0, top * 1.25, padding=0)      # headroom for the line's label and the flags
            step = 1 if n <= 25 else (2 if n <= 50 else 5)
            ticks = [(float(p), str(int(p))) for i, p in enumerate(self._pairs) if i % step == 0]
            plot.getAxis("bottom").setTicks([ticks])
        else:
            plot.getAxis("bottom").setTicks(None)
        self.line.setBounds((0.0, top * 1.2))
        if auto_threshold is not None and np.isfinite(auto_threshold) and n:
            self.auto_line.setValue(float(auto_threshold))
            self.auto_line.show()
        else:
            self.auto_line.hide()
        self.line.setVisible(n > 0)
        for line in (self.line, self.auto_line):
            line.label.valueChanged()       # a hidden label does not follow setValue
        self._draw_flags(top)
        start = threshold if threshold is not None else top * 1.06
        self.line.blockSignals(True)
        self.line.setValue(float(start))
        self.line.blockSignals(False)
        self.line.label.valueChanged()
        self._selected = []
        self._line_moved()

    def clear_errors(self) -> None:
        self.set_errors([], [], [])

    def _draw_flags(self, top: float) -> None:
        if not len(self._pairs) or not self._flagged.any():
            self.flags.setData([], [])
            return
        k = np.flatnonzero(self._flagged)
        y = np.maximum(self._left[k], self._right[k]) + 0.05 * top
        self.flags.setData(self._pairs[k], y)

    # -- threshold ------------------------------------------------------------------------
    def threshold(self) -> float:
        return float(self.line.value())

    def set_threshold(self, value: float) -> None:
        self.line.setValue(float(value))    # emits sigPositionChanged -> _line_moved

    def selected(self) -> list[int]:
        """Rows (0-based positions in the arrays given to set_errors) above the line."""
        return list(self._selected)

    def _line_moved(self, *_) -> None:
        t = self.threshold()
        above = np.maximum(self._left, self._right) > t if len(self._pairs) else np.zeros(0, bool)
        lb = [colour(SELECTED_LEFT) if a else colour(LEFT) for a in above]
        rb = [colour(SELECTED_RIGHT) if a else colour(RIGHT) for a in above]
        self.left_bars.setOpts(x=self._pairs - WIDTH / 2, height=self._left, brushes=lb)
        self.right_bars.setOpts(x=self._pairs + WIDTH / 2, height=self._right, brushes=rb)
        selected = [int(i) for i in np.flatnonzero(above)]
        if selected != self._selected:
            self._selected = selected
            self.selectionChanged.emit(list(selected))

    def series(self) -> dict[str, np.ndarray]:
        """What is drawn (tests): pairs, left, right, flagged."""
        return {"pairs": self._pairs.copy(), "left": self._left.copy(), "right": self._right.copy(),
                "flagged": self._flagged.copy()}
