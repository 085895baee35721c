"""The Marker page's stereo line above the tabs: where the stereo rectification comes from, and
in the virtual lab without a calibration the button for a preview with the lab's true cameras."""
from __future__ import annotations

from PySide6.QtWidgets import QHBoxLayout, QLabel, QWidget

from app.html import esc
from app.pages.forms import button
from app.pages.measurement_inputs import StereoSource


class StereoBar(QWidget):
    """`stereo_label` and `preview_button` (the page connects it); `draw(source, virtual)`."""

    def __init__(self, parent: QWidget | None = None):
        super().__init__(parent)
        self.stereo_label = QLabel()
        self.stereo_label.setObjectName("hint")
        self.stereo_label.setWordWrap(True)
        self.preview_button = button(
            "Preview with the lab's true cameras", "previewButton",
            tooltip="No stereo calibration yet: locate with the virtual lab's true cameras, clearly labelled as "
                    "a preview. Measurements need stereo.yaml.")
        layout = QHBoxLayout(self)
        layout.setContentsMargins(0, 0, 0, 0)
        layout.setSpacing(8)
        layout.addWidget(self.stereo_label, 1)
        layout.addWidget(self.preview_button)

    def draw(self, src: StereoSource, virtual: bool) -> None:
        """Say where the rectification comes from (or why there is none); the preview button
        only in the virtual lab without one."""
        if src.rect is None:
            hint = (" In the virtual lab you can preview the location with the lab's true cameras."
                    if virtual else " Calibrate the cameras in step 2 first.")
            self.stereo_label.setText(f"<span style='color:#b06000'><b>Stereo:</b> {esc(src.problem)}.</span>{hint}")
        elif src.kind == "preview":
            self.stereo_label.setText(f"<b style='color:#b06000'>{esc(src.label)}</b>")
        else:
            self.stereo_label.setText(f"<b>Stereo:</b> {esc(src.label)}")
        self.preview_button.setVisible(virtual and src.rect is None)
