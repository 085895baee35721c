"""Keep a widget's wrapped rows visible where Qt asks only for a minimum size, not a height
for a width — a QSplitter's pane, a page in a scroll area: `hold_height_for_width(box)` makes the
box's minimum height its layout's height at its current width, so on a narrow window its
word-wrapped labels and FlowLayout rows take more lines instead of overlapping or being cut."""
from __future__ import annotations

from PySide6.QtCore import QEvent, QObject, QTimer
from PySide6.QtWidgets import QWidget


class _HeightFollowsWidth(QObject):
    def eventFilter(self, obj, event) -> bool:
        if event.type() == QEvent.Type.Resize and event.size().width() != event.oldSize().width():
            # after the resize is laid out: changed during it, the layout would keep its old geometry
            QTimer.singleShot(0, obj, lambda: self._follow(obj))
        return False

    @staticmethod
    def _follow(widget: QWidget) -> None:
        layout = widget.layout()
        if layout is not None and layout.hasHeightForWidth():
            widget.setMinimumHeight(layout.totalHeightForWidth(widget.width()))


def hold_height_for_width(widget: QWidget) -> QWidget:
    """`widget`'s minimum height follows its width (its layout's height for that width)."""
    keeper = _HeightFollowsWidth(widget)
    widget.installEventFilter(keeper)
    return widget
