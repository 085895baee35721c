"""Per-corner reprojection residuals (observed − projected, px) of two cameras as a scatter
plot with equal axes, centred on zero, with an optional highlighted subset (e.g. one pair).

`set_residuals(left, right)` with (M, 2) arrays; `set_highlight(left, right)` or
`set_highlight(None, None)`."""
from __future__ import annotations

import numpy as np
import pyqtgraph as pg

from widgets.plot_theme import AXIS, colour, legend, style_plot

LEFT = "#1a73e8"
RIGHT = "#e37400"
HIGHLIGHT = "#202124"


def _xy(a) -> np.ndarray:
    if a is None:
        return np.zeros((0, 2))
    a = np.asarray(a, dtype=float).reshape(-1, 2)
    return a[np.all(np.isfinite(a), axis=1)]


class ResidualScatter(pg.PlotWidget):
    def __init__(self, parent=None, *, names: tuple[str, str] = ("left camera", "right camera")):
        super().__init__(parent=parent, background="w", enableMenu=False)
        self.setObjectName("residualScatter")
        plot = self.getPlotItem()
        style_plot(plot, "residual x (px)", "residual y (px)")
        plot.setAspectLocked(True, ratio=1.0)
        plot.invertY(True)          # image convention: y down, as in the images
        self.left_points = pg.ScatterPlotItem(size=4, pen=None, brush=colour(LEFT, 150))
        self.right_points = pg.ScatterPlotItem(size=4, pen=None, brush=colour(RIGHT, 150))
        self.highlight = pg.ScatterPlotItem(size=8, pen=pg.mkPen(HIGHLIGHT, width=1.2), brush=None, symbol="o")
        zero = pg.mkPen(AXIS, width=1)
        self.x_axis_line = pg.InfiniteLine(pos=0, angle=0, pen=zero)
        self.y_axis_line = pg.InfiniteLine(pos=0, angle=90, pen=zero)
        for item in (self.x_axis_line, self.y_axis_line, self.left_points, self.right_points, self.highlight):
            plot.addItem(item)
        self.legend = legend(plot)
        self.legend.addItem(self.left_points, names[0])
        self.legend.addItem(self.right_points, names[1])
        self._highlight_in_legend = False
        self._left = np.zeros((0, 2))
        self._right = np.zeros((0, 2))

    def set_residuals(self, left, right) -> None:
        self._left, self._right = _xy(left), _xy(right)
        self.left_points.setData(self._left[:, 0], self._left[:, 1])
        self.right_points.setData(self._right[:, 0], self._right[:, 1])
        both = np.concatenate([self._left, self._right])
        r = float(np.abs(both).max()) * 1.15 if len(both) else 1.0
        r = r if r > 0 else 1.0
        plot = self.getPlotItem()
        # the legend sits in the top right corner: leave it some room above the points
        plot.setXRange(-r, r, padding=0)
        plot.setYRange(-r * 1.35, r, padding=0)

    def set_highlight(self, left=None, right=None, name: str = "selected pair") -> None:
        """Circle a subset of the points (e.g. one pair's corners); None, None removes it."""
        pts = np.concatenate([_xy(left), _xy(right)])
        self.highlight.setData(pts[:, 0], pts[:, 1])
        if self._highlight_in_legend:
            self.legend.removeItem(self.highlight)
            self._highlight_in_legend = False
        if len(pts):
            self.legend.addItem(self.highlight, name)
            self._highlight_in_legend = True

    def clear_residuals(self) -> None:
        self.set_residuals(None, None)
        self.set_highlight(None, None)

    def counts(self) -> tuple[int, int]:
        return len(self._left), len(self._right)
