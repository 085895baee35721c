"""A widget whose minimum height follows its width, for a box of wrapping rows (word-wrapped
labels, a FlowLayout) placed where Qt asks only for a minimum size, not a height for a width —
a QSplitter's pane, for example: on a narrow window the rows wrap onto more lines, and the pane
keeps room for them instead of letting them overlap."""
from __future__ import annotations

from PySide6.QtCore import QSize
from PySide6.QtWidgets import QWidget


class WrappingBox(QWidget):
    """Give it a layout as any QWidget; its minimum height is the layout's height at its width."""

    def minimumSizeHint(self) -> QSize:
        hint = super().minimumSizeHint()
        layout = self.layout()
        if layout is not None and layout.hasHeightForWidth() and self.width() > 0:
            hint.setHeight(max(hint.height(), layout.totalHeightForWidth(max(self.width(), hint.width()))))
        return hint

    def resizeEvent(self, event) -> None:
        super().resizeEvent(event)
        if event.size().width() != event.oldSize().width():
            self.updateGeometry()          # the rows wrap differently: a new minimum height
