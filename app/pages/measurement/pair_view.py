"""The live pair: the last pose's left | right images with what the locator found."""
from __future__ import annotations

from PySide6.QtWidgets import QLabel, QVBoxLayout, QWidget

from app.jobs.measurement import MEASURED
from app.pages.measurement.texts import short
from widgets.image_view import ImageView


class PairView(QWidget):
    """A caption over the thumbnail (app.jobs.measurement.pair_thumbnail's image)."""

    def __init__(self, parent: QWidget | None = None):
        super().__init__(parent)
        self.thumb = ImageView()
        self.thumb.setObjectName("pairThumbnail")
        self.thumb.setMinimumHeight(120)
        self.label = QLabel("Current pair: left | right")
        self.label.setObjectName("hint")
        layout = QVBoxLayout(self)
        layout.setContentsMargins(0, 0, 0, 0)
        layout.setSpacing(2)
        layout.addWidget(self.label)
        layout.addWidget(self.thumb, 1)

    def follow(self, model) -> None:
        """Show the pair of each pose a MeasurementModel reports done ("pose", with a thumbnail)."""
        model.on("pose", self._pose_done)

    def _pose_done(self, shown) -> None:
        if shown.thumbnail is not None:
            self.show_pair(shown.row.pose, shown.thumbnail, shown.row.status == MEASURED, shown.row.reason)

    def show_pair(self, pose: int, thumb, measured: bool, reason: str) -> None:
        self.thumb.set_image(thumb)
        outcome = "located" if measured else f"rejected: {short(reason, 60)}"
        self.label.setText(f"Pose {pose}: left | right — {outcome}")
