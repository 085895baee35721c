"""The Marker page's SSD correlation tab: the criteria curve along the epipolar line (Fig. 16)
and the window-size sweep (Fig. 17) of the last live pair."""
from __future__ import annotations

import numpy as np
from PySide6.QtCore import Qt
from PySide6.QtWidgets import QLabel, QSplitter, QVBoxLayout, QWidget

from app.jobs.marker import LiveResult
from widgets.ssd_plots import CriteriaPlot, WindowSweepPlot


class SsdPanel(QWidget):
    """The SSD correlation tab; the page calls `draw(live)`."""

    def __init__(self, parent: QWidget | None = None):
        super().__init__(parent)
        self.criteria_plot = CriteriaPlot()
        self.sweep_plot = WindowSweepPlot()
        self.ssd_note = QLabel()
        self.ssd_note.setObjectName("hint")
        self.ssd_note.setWordWrap(True)
        layout = QVBoxLayout(self)
        layout.setContentsMargins(4, 4, 4, 4)
        split = QSplitter(Qt.Orientation.Vertical)
        split.addWidget(self.criteria_plot)
        split.addWidget(self.sweep_plot)
        split.setChildrenCollapsible(False)
        layout.addWidget(split, 1)
        layout.addWidget(self.ssd_note)

    def draw(self, live: LiveResult | None) -> None:
        """The criteria curve and the sweep of `live` (None: empty plots)."""
        if live is None:
            self.criteria_plot.clear_curve()
            self.sweep_plot.clear_sweep()
            self.ssd_note.setText("The criteria curve and the window-size sweep appear after a live pair.")
            return
        c = live.location.correspondence
        if c is None:
            self.criteria_plot.clear_curve()
            self.ssd_note.setText("No SSD search: the marker was not found in the left image.")
        else:
            self._draw_criteria(c)
        if live.sweep is not None:
            s = live.sweep
            located = c.disparity if c is not None and c.ok else None
            self.sweep_plot.set_sweep(s.sizes, s.minima, s.disparities, located)
        else:
            self.sweep_plot.clear_sweep()

    def _draw_criteria(self, c) -> None:
        """Fig. 16 from a core.marker.correspondence result."""
        plain = np.asarray(c.plain_criteria if c.plain_criteria is not None else c.criteria, float)
        second = None
        hits = np.flatnonzero(plain == c.plain_second_minimum) if len(plain) else []
        if len(hits):
            second = (float(c.disparities[hits[0]]), float(c.plain_second_minimum))
        self.criteria_plot.set_curve(c.disparities, plain, minimum=(c.plain_disparity, c.plain_minimum),
                                     second=second, searched=c.criteria if c.warped else None,
                                     disparity=c.disparity)
        self.ssd_note.setText(
            f"Window {c.window[1]}×{c.window[0]} px (the marker's apparent size) on the left reference point, "
            f"slid along the same row of the rectified right image: d* = {c.disparity:.2f} px, reliability "
            f"{c.reliability:.3f} (best / second-best minimum: 0 unique … 1 ambiguous). Below, square windows of "
            "5…37 px at the same point: the lowest criteria grows with the window, which covers more of what "
            "differs between the two views; too small a window sees too little texture and may find its "
            "minimum elsewhere (red), a wrong match.")
