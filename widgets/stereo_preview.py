"""Two camera images side by side (left, right) with a caption: the live preview."""
from __future__ import annotations

import numpy as np
from PySide6.QtCore import Qt
from PySide6.QtGui import QImage, QPixmap
from PySide6.QtWidgets import QHBoxLayout, QLabel, QSizePolicy, QVBoxLayout, QWidget


def to_pixmap(image: np.ndarray) -> QPixmap:
    """A uint8 grey (H, W) or BGR (H, W, 3) image as a QPixmap."""
    image = np.ascontiguousarray(image)
    h, w = image.shape[:2]
    if image.ndim == 2:
        qimage = QImage(image.data, w, h, image.strides[0], QImage.Format.Format_Grayscale8)
    else:
        qimage = QImage(image.data, w, h, image.strides[0], QImage.Format.Format_BGR888)
    return QPixmap.fromImage(qimage.copy())


class StereoPreview(QWidget):
    """`show_pair(left, right)` draws both; `set_caption(text)` the line below."""

    def __init__(self, parent: QWidget | None = None, *, min_width: int = 160):
        super().__init__(parent)
        self.left = QLabel("left camera")
        self.right = QLabel("right camera")
        for label, name in ((self.left, "leftPreview"), (self.right, "rightPreview")):
            label.setObjectName(name)
            label.setAlignment(Qt.AlignmentFlag.AlignCenter)
            label.setMinimumSize(min_width, int(min_width * 0.75))
            label.setSizePolicy(QSizePolicy.Policy.Ignored, QSizePolicy.Policy.Ignored)
            label.setStyleSheet("background: #202124; color: #9aa0a6;")
        self.caption = QLabel()
        self.caption.setObjectName("hint")
        images = QHBoxLayout()
        images.setContentsMargins(0, 0, 0, 0)
        images.addWidget(self.left, 1)
        images.addWidget(self.right, 1)
        layout = QVBoxLayout(self)
        layout.setContentsMargins(0, 0, 0, 0)
        layout.addLayout(images, 1)
        layout.addWidget(self.caption)

    def show_pair(self, left: np.ndarray, right: np.ndarray) -> None:
        for label, image in ((self.left, left), (self.right, right)):
            pix = to_pixmap(image)
            label.setPixmap(pix.scaled(label.size(), Qt.AspectRatioMode.KeepAspectRatio,
                                       Qt.TransformationMode.FastTransformation))

    def clear(self, text: str = "") -> None:
        for label, side in ((self.left, "left"), (self.right, "right")):
            label.clear()
            label.setText(text or f"{side} camera")

    def set_caption(self, text: str) -> None:
        self.caption.setText(text)
