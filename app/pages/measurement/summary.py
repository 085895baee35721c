"""The Measurement page's summary under the views: measured, rejected and pending poses, what
identification needs, the commonest rejection reasons, the median predicted σ (texts.summary_html)."""
from __future__ import annotations

from PySide6.QtCore import Qt
from PySide6.QtWidgets import QLabel, QWidget

from app.pages.measurement.texts import summary_html


class SummaryLabel(QLabel):
    """After `follow(model)` it shows a MeasurementModel's summary as its rows change."""

    def __init__(self, parent: QWidget | None = None):
        super().__init__(parent)
        self.setObjectName("summaryLabel")
        self.setWordWrap(True)
        self.setTextFormat(Qt.TextFormat.RichText)

    def follow(self, model) -> None:
        for event in ("rows", "pose"):
            model.on(event, lambda _value: self.setText(summary_html(model.rows, model.n_min)))
