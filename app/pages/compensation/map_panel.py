"""The Compensation page's accuracy map: how many targets, the button that measures it, the
plot of error vectors and error lengths, and the figures in words."""
from __future__ import annotations

from PySide6.QtWidgets import QGroupBox, QVBoxLayout

from app.pages import forms
from app.pages.compensation.model import MeasuredMap
from widgets.accuracy_map_plot import AccuracyMapPlot

NO_MAP = ("No accuracy map yet: it moves the robot to a grid of targets twice (nominal and calibrated model) "
          "and measures each landing with the cameras.")


class MapPanel(QGroupBox):
    def __init__(self, parent=None):
        super().__init__("Accuracy before and after", parent)
        self.count_spin = forms.spin(20, 4, 200, name="mapCount", suffix=" targets",
                                     tooltip="Targets of the grid in the calibrated workspace")
        self.measure_button = forms.button("Measure accuracy map", "measureMapButton",
                                           tooltip="Reach each target with the nominal and with the calibrated "
                                                   "model and measure where the marker lands with the cameras")
        self.plot = AccuracyMapPlot()
        self.plot.setMinimumHeight(260)
        self.summary = forms.WrappedLabel(NO_MAP)
        self.summary.setObjectName("mapSummary")
        self.summary.setWordWrap(True)
        layout = QVBoxLayout(self)
        layout.addLayout(forms.row(self.count_spin, self.measure_button))
        layout.addWidget(self.plot, 1)
        layout.addWidget(self.summary)

    def options(self) -> int:
        """How many targets the accuracy map has."""
        return self.count_spin.value()

    def show_options(self, targets: int) -> None:
        self.count_spin.setValue(targets)

    def show_map(self, measured: MeasuredMap | None) -> None:
        """Draw the model's result (None: no map, the plot cleared)."""
        self.plot.set_map(measured.amap if measured is not None else None)
        if measured is None:
            self.summary.setText(NO_MAP)
            return
        path = measured.path
        self.summary.setText(measured.amap.summary() + (f" Written to {path.name}." if path is not None else ""))
