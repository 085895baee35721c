"""Cost (or RMS error) per iteration of an iterative fit, on a logarithmic axis.

`set_history(iterations, values, stages)`: one value per iteration; where `stages` changes
(e.g. "fit" → "refine" → "huber 1") a dashed vertical line names the new stage."""
from __future__ import annotations

import numpy as np
import pyqtgraph as pg

from widgets.plot_theme import AFTER, AXIS, TEXT, readable_axes, style_plot

TINY = 1e-30     # a zero cost (noise-free data) still has a place on the log axis


class ConvergencePlot(pg.PlotWidget):
    def __init__(self, y_label: str = "cost Σ w·e² (mm²)", parent=None):
        super().__init__(parent=parent, background="w", axisItems=readable_axes(), enableMenu=False)
        style_plot(self.getPlotItem(), "iteration", y_label)
        self.setObjectName("convergencePlot")
        self.curve = pg.PlotDataItem(pen=pg.mkPen(AFTER, width=2), symbol="o", symbolSize=7,
                                     symbolBrush=AFTER, symbolPen=pg.mkPen("w"))
        self.addItem(self.curve)
        self.getPlotItem().setLogMode(y=True)
        self._markers: list[pg.InfiniteLine] = []
        self.x = np.zeros(0)
        self.y = np.zeros(0)


    def set_history(self, iterations, values, stages=None) -> None:
        for line in self._markers:
            self.removeItem(line)
        self._markers.clear()
        self.x = np.asarray(iterations, dtype=float).reshape(-1)
        self.y = np.maximum(np.asarray(values, dtype=float).reshape(-1), TINY)
        self.curve.setData(self.x, self.y)
        if stages is not None:
            previous = None
            for x, stage in zip(self.x, stages):
                if previous is not None and stage != previous:
                    line = pg.InfiniteLine(pos=x, angle=90, pen=pg.mkPen(AXIS, style=pg.QtCore.Qt.PenStyle.DashLine),
                                           label=str(stage), labelOpts={"position": 0.92, "color": TEXT,
                                                                        "fill": (255, 255, 255, 200)})
                    self.addItem(line)
                    self._markers.append(line)
                previous = stage
        if len(self.x):
            self.setXRange(float(self.x.min()) - 0.3, float(self.x.max()) + 0.3, padding=0)
            ly = np.log10(self.y)
            span = max(float(ly.max() - ly.min()), 0.5)
            self.setYRange(float(ly.min()) - 0.08 * span, float(ly.max()) + 0.08 * span, padding=0)

    def clear_history(self) -> None:
        self.set_history([], [])
