"""Where the measurements come from: the project's measurements.csv, or (virtual lab, for
teaching) ideal synthetic ones."""
from __future__ import annotations

from typing import Callable

from PySide6.QtCore import Qt
from PySide6.QtWidgets import QGroupBox, QHBoxLayout, QLabel, QSizePolicy

from app.lab import DEFAULT_POSES, DEFAULT_SIGMA_MM
from app.pages.forms import button

IDEAL_BUTTON_TEXT = "Use ideal virtual-lab measurements (no images)"


class SourcePanel(QGroupBox):
    """The measurements line and the ideal-measurements button (`on_ideal()` when clicked)."""

    def __init__(self, *, on_ideal: Callable, parent=None):
        super().__init__("Measurements", parent)
        self.source_label = QLabel()
        self.source_label.setObjectName("sourceLabel")
        self.source_label.setWordWrap(True)
        self.source_label.setTextInteractionFlags(Qt.TextInteractionFlag.TextSelectableByMouse)
        self.ideal_button = button(
            IDEAL_BUTTON_TEXT, "idealButton", on_click=on_ideal,
            tooltip=f"Teaching aid: the virtual lab's TRUE robot at {DEFAULT_POSES} random poses where both cameras "
                    f"see the marker, plus Gaussian noise σ = {DEFAULT_SIGMA_MM:g} mm. No images are rendered or "
                    "measured. Written to the project's measurements.csv, marked as synthetic.")
        layout = QHBoxLayout(self)
        layout.addWidget(self.source_label, 1)
        layout.addWidget(self.ideal_button, 0, Qt.AlignmentFlag.AlignTop)
        self.setSizePolicy(QSizePolicy.Policy.Preferred, QSizePolicy.Policy.Maximum)

    def show_source(self, html: str, *, offer_ideal: bool) -> None:
        self.source_label.setText(html)
        self.ideal_button.setVisible(offer_ideal)
