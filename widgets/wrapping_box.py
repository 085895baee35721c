"""Keep a box's wrapped rows visible where Qt asks only for a minimum size, not a height for a
width (a splitter's pane; a box inside a page that scrolls): `hold_height_for_width(box)` makes
the box's minimum height its layout's height at its current width, again when its rows change, so
on a narrow window its word-wrapped labels and FlowLayout rows take more lines instead of being
cut or overlapping."""
from __future__ import annotations

from PySide6.QtCore import QEvent, QObject, QTimer
from PySide6.QtWidgets import QWidget


class _HeightFollowsWidth(QObject):
    def eventFilter(self, obj, event) -> bool:
        if ((event.type() == QEvent.Type.Resize and event.size().width() != event.oldSize().width())
                or event.type() == QEvent.Type.LayoutRequest):       # or its rows changed
            # after the resize is laid out: changed during it, the layout would keep its old geometry
            QTimer.singleShot(0, obj, lambda: self._follow(obj))
        return False

    @staticmethod
    def _follow(widget: QWidget) -> None:
        layout = widget.layout()
        if layout is None or not layout.hasHeightForWidth():
            return
        height = layout.totalHeightForWidth(widget.width())
        if height == widget.minimumHeight():
            return
        widget.setMinimumHeight(height)
        parent = widget.parentWidget()
        if parent is not None and parent.layout() is not None:
            parent.layout().activate()      # place it and its siblings again now, at its new height


def hold_height_for_width(widget: QWidget) -> QWidget:
    """`widget`'s minimum height follows its width (its layout's height for that width)."""
    keeper = _HeightFollowsWidth(widget)
    widget.installEventFilter(keeper)
    return widget
