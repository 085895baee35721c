"""A horizontal strip of image thumbnails, each with a caption, a tool tip and an optional
badge (a coloured band with a short text, e.g. why a checkerboard pair was rejected).

The pictures of stereo pairs come from core.thumbnails (plain numpy/OpenCV, made on
a worker thread). The strip takes row-major RGB (or grey) uint8 arrays and knows nothing of where
they come from. Items are addressed by a key of the caller's choice.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Hashable

import numpy as np
from PySide6.QtCore import QRect, QSize, Qt, Signal
from PySide6.QtGui import QColor, QFont, QIcon, QImage, QPainter, QPixmap
from PySide6.QtWidgets import QAbstractItemView, QListView, QListWidget, QListWidgetItem, QWidget

KEY_ROLE = Qt.ItemDataRole.UserRole + 1
BAD = "#c5221f"       # rejected
MUTED = "#5f6368"     # excluded by the user, or other neutral states
WARN = "#b06000"      # flagged


def to_qimage(image: np.ndarray) -> QImage:
    """A QImage that owns a copy of a row-major grey or RGB uint8 array."""
    arr = np.ascontiguousarray(image, dtype=np.uint8)
    h, w = arr.shape[:2]
    if arr.ndim == 2:
        return QImage(arr.data, w, h, arr.strides[0], QImage.Format.Format_Grayscale8).copy()
    if arr.shape[2] == 4:
        return QImage(arr.data, w, h, arr.strides[0], QImage.Format.Format_RGBA8888).copy()
    return QImage(arr.data, w, h, arr.strides[0], QImage.Format.Format_RGB888).copy()


@dataclass
class _Entry:
    image: np.ndarray
    caption: str
    badge: str | None
    badge_colour: str
    tooltip: str


class ThumbnailStrip(QListWidget):
    """`add(key, image, caption, badge=None, badge_colour=BAD, tooltip="")`, `update(key, ...)`,
    `remove(key)`, `clear_all()`, `keys()`, `selected_keys()`, `badge(key)`.
    Signal `currentKeyChanged(object)` (None when nothing is selected)."""

    currentKeyChanged = Signal(object)

    def __init__(self, parent: QWidget | None = None, *, icon_size: QSize = QSize(244, 96)):
        super().__init__(parent)
        self.setObjectName("thumbnailStrip")
        self.setViewMode(QListView.ViewMode.IconMode)
        self.setFlow(QListView.Flow.LeftToRight)
        self.setWrapping(False)
        self.setMovement(QListView.Movement.Static)
        self.setResizeMode(QListView.ResizeMode.Adjust)
        self.setHorizontalScrollMode(QAbstractItemView.ScrollMode.ScrollPerPixel)
        self.setSelectionMode(QAbstractItemView.SelectionMode.ExtendedSelection)
        self.setIconSize(icon_size)
        self.setSpacing(3)
        self.setUniformItemSizes(True)
        self.setWordWrap(False)
        self.setTextElideMode(Qt.TextElideMode.ElideRight)
        self.setFixedHeight(icon_size.height() + 48)
        self._entries: dict[Hashable, _Entry] = {}
        self._items: dict[Hashable, QListWidgetItem] = {}
        self.currentItemChanged.connect(lambda cur, _prev: self.currentKeyChanged.emit(
            None if cur is None else cur.data(KEY_ROLE)))

    # -- content --------------------------------------------------------------------------
    def add(self, key: Hashable, image: np.ndarray, caption: str, badge: str | None = None,
            badge_colour: str = BAD, tooltip: str = "") -> None:
        if key in self._items:
            raise KeyError(f"thumbnail {key!r} exists")
        item = QListWidgetItem()
        item.setData(KEY_ROLE, key)
        item.setTextAlignment(Qt.AlignmentFlag.AlignHCenter | Qt.AlignmentFlag.AlignTop)
        item.setSizeHint(QSize(self.iconSize().width() + 10, self.iconSize().height() + 26))
        self._items[key] = item
        self._entries[key] = _Entry(np.asarray(image), caption, badge, badge_colour, tooltip)
        self.addItem(item)
        self._render(key)

    def update(self, key: Hashable, *, caption: str | None = None, badge: str | None | bool = False,
               badge_colour: str | None = None, tooltip: str | None = None) -> None:
        """Change what is shown for `key` (badge=None removes the badge; False keeps it)."""
        e = self._entries[key]
        changed = False
        if caption is not None and caption != e.caption:
            e.caption, changed = caption, True
        if badge is not False and badge != e.badge:
            e.badge, changed = badge, True
        if badge_colour is not None and badge_colour != e.badge_colour:
            e.badge_colour, changed = badge_colour, True
        if tooltip is not None and tooltip != e.tooltip:
            e.tooltip, changed = tooltip, True
        if changed:
            self._render(key)

    def remove(self, key: Hashable) -> None:
        item = self._items.pop(key)
        self._entries.pop(key)
        self.takeItem(self.row(item))

    def clear_all(self) -> None:
        self.clear()
        self._items.clear()
        self._entries.clear()

    def keys(self) -> list:
        return [self.item(r).data(KEY_ROLE) for r in range(self.count())]

    def selected_keys(self) -> list:
        rows = sorted(self.row(i) for i in self.selectedItems())
        return [self.item(r).data(KEY_ROLE) for r in rows]

    def select_key(self, key: Hashable) -> None:
        item = self._items.get(key)
        if item is not None:
            self.setCurrentItem(item)
            self.scrollToItem(item)

    def caption(self, key: Hashable) -> str:
        return self._entries[key].caption

    def badge(self, key: Hashable) -> str | None:
        return self._entries[key].badge

    def tooltip(self, key: Hashable) -> str:
        return self._entries[key].tooltip

    # -- drawing --------------------------------------------------------------------------
    def _render(self, key: Hashable) -> None:
        e, item = self._entries[key], self._items[key]
        pixmap = QPixmap.fromImage(to_qimage(e.image))
        if e.badge:
            painter = QPainter(pixmap)
            font = QFont(self.font())
            font.setPointSizeF(7.5)
            font.setBold(True)
            painter.setFont(font)
            band = max(14, painter.fontMetrics().height() + 3)
            rect = QRect(0, pixmap.height() - band, pixmap.width(), band)
            colour = QColor(e.badge_colour)
            colour.setAlpha(225)
            painter.fillRect(rect, colour)
            painter.setPen(QColor("white"))
            text = painter.fontMetrics().elidedText(e.badge, Qt.TextElideMode.ElideRight, rect.width() - 8)
            painter.drawText(rect.adjusted(4, 0, -4, 0), int(Qt.AlignmentFlag.AlignVCenter
                                                             | Qt.AlignmentFlag.AlignLeft), text)
            painter.end()
        item.setIcon(QIcon(pixmap))
        item.setText(e.caption)
        item.setToolTip(e.tooltip or e.caption)
