"""widgets.png: a QImage as PNG bytes, every pixel kept."""
from __future__ import annotations

import numpy as np
from PySide6.QtGui import QColor, QImage

from widgets.png import png_bytes


def test_every_pixel_comes_back_and_a_null_image_gives_no_bytes(qapp):
    image = QImage(64, 48, QImage.Format.Format_RGB32)
    rng = np.random.default_rng(0)
    for y in range(image.height()):
        for x in range(image.width()):
            image.setPixelColor(x, y, QColor(*(int(v) for v in rng.integers(0, 256, 3))))
    data = png_bytes(image)
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    back = QImage.fromData(data, "PNG").convertToFormat(QImage.Format.Format_RGB32)
    assert back.size() == image.size() and back == image
    assert png_bytes(QImage()) == b""
