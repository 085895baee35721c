"""Coverage bars in the ROS camera_calibration style: one bar per measure in [0, 1]
(e.g. X, Y, size, skew), green once it reaches the threshold, amber below, with its value.

`set_values({"X": 0.8, ...})`; `values()` returns what is shown (tests)."""
from __future__ import annotations

from typing import Mapping, Sequence

from PySide6.QtCore import Qt
from PySide6.QtWidgets import QGridLayout, QLabel, QProgressBar, QWidget

GOOD = "#188038"
LOW = "#e37400"
_BAR_STYLE = ("QProgressBar {{ border: 1px solid #dadce0; border-radius: 3px; background: #f1f3f4; "
              "min-height: 12px; max-height: 12px; }}"
              "QProgressBar::chunk {{ background: {colour}; border-radius: 2px; }}")


class CoverageBars(QWidget):
    """Bars laid out in one row (`columns=len(names)`) or in a grid."""

    def __init__(self, names: Sequence[str] = ("X", "Y", "size", "skew"), *, threshold: float = 0.6,
                 labels: Mapping[str, str] | None = None, tooltips: Mapping[str, str] | None = None,
                 columns: int | None = None, parent: QWidget | None = None):
        super().__init__(parent)
        self.setObjectName("coverageBars")
        self.names = list(names)
        self.threshold = float(threshold)
        self._values = {n: 0.0 for n in self.names}
        self.bars: dict[str, QProgressBar] = {}
        self.value_labels: dict[str, QLabel] = {}
        labels = dict(labels or {})
        tooltips = dict(tooltips or {})
        columns = columns or len(self.names)
        grid = QGridLayout(self)
        grid.setContentsMargins(0, 0, 0, 0)
        grid.setHorizontalSpacing(6)
        grid.setVerticalSpacing(4)
        for i, name in enumerate(self.names):
            r, c = divmod(i, columns)
            label = QLabel(labels.get(name, name))
            bar = QProgressBar()
            bar.setRange(0, 1000)
            bar.setTextVisible(False)
            bar.setMinimumWidth(40)
            value = QLabel("0.00")
            value.setObjectName("hint")
            value.setAlignment(Qt.AlignmentFlag.AlignRight | Qt.AlignmentFlag.AlignVCenter)
            value.setMinimumWidth(value.fontMetrics().horizontalAdvance("0.00") + 4)
            tip = tooltips.get(name, "")
            for w in (label, bar, value):
                w.setToolTip(tip)
            grid.addWidget(label, r, 3 * c)
            grid.addWidget(bar, r, 3 * c + 1)
            grid.addWidget(value, r, 3 * c + 2)
            grid.setColumnStretch(3 * c + 1, 1)
            if c < columns - 1:
                grid.setColumnMinimumWidth(3 * c + 2, value.minimumWidth() + 10)
            self.bars[name] = bar
            self.value_labels[name] = value
        self.set_values(self._values)

    def set_values(self, values: Mapping[str, float]) -> None:
        for name in self.names:
            v = float(values.get(name, 0.0))
            v = min(max(v, 0.0), 1.0) if v == v else 0.0
            self._values[name] = v
            bar = self.bars[name]
            bar.setValue(int(round(v * 1000)))
            bar.setStyleSheet(_BAR_STYLE.format(colour=GOOD if v >= self.threshold else LOW))
            self.value_labels[name].setText(f"{v:.2f}")

    def values(self) -> dict[str, float]:
        return dict(self._values)

