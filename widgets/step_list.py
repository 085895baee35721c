"""A side list of numbered steps, each with a state: to do / done / out of date (or failed to load)."""
from __future__ import annotations

from enum import Enum

from PySide6.QtCore import QPointF, QRect, QRectF, QSize, Qt
from PySide6.QtGui import (QBrush, QColor, QFont, QFontMetrics, QIcon, QPainter, QPainterPath, QPen,
                           QPixmap)
from PySide6.QtWidgets import (QAbstractItemView, QListWidget, QListWidgetItem, QStyle,
                               QStyledItemDelegate, QStyleOptionViewItem, QWidget)


class StepState(Enum):
    TODO = "to do"
    DONE = "done"
    STALE = "out of date: run again"
    ERROR = "failed to load"


_COLOURS = {
    StepState.TODO: QColor("#1a73e8"),
    StepState.DONE: QColor("#188038"),
    StepState.STALE: QColor("#b06000"),
    StepState.ERROR: QColor("#c5221f"),
}


def state_icon(state: StepState, number: int, size: int = 28) -> QIcon:
    """A round badge: the step number in a ring (to do; amber: out of date), on a green disc with
    a tick (done), on a red disc (failed to load)."""
    scale = 2
    pix = QPixmap(size * scale, size * scale)
    pix.setDevicePixelRatio(scale)
    pix.fill(Qt.GlobalColor.transparent)
    p = QPainter(pix)
    p.setRenderHint(QPainter.RenderHint.Antialiasing)
    colour = _COLOURS[state]
    rect = QRectF(2, 2, size - 4, size - 4)
    if state in (StepState.DONE, StepState.ERROR):
        p.setPen(Qt.PenStyle.NoPen)
        p.setBrush(QBrush(colour))
        p.drawEllipse(rect)
    else:
        p.setPen(QPen(colour, 2))
        p.setBrush(Qt.BrushStyle.NoBrush)
        p.drawEllipse(rect)
    if state is StepState.DONE:
        tick = QPainterPath(QPointF(size * 0.29, size * 0.52))
        tick.lineTo(QPointF(size * 0.44, size * 0.67))
        tick.lineTo(QPointF(size * 0.72, size * 0.36))
        p.setPen(QPen(QColor("white"), 2.6, Qt.PenStyle.SolidLine, Qt.PenCapStyle.RoundCap,
                      Qt.PenJoinStyle.RoundJoin))
        p.drawPath(tick)
    else:
        font = QFont()
        font.setPixelSize(int(size * 0.46))
        font.setBold(True)
        p.setFont(font)
        p.setPen(QColor("white") if state is StepState.ERROR else colour)
        p.drawText(rect, Qt.AlignmentFlag.AlignCenter, "!" if state is StepState.ERROR else str(number))
    p.end()
    return QIcon(pix)


class _StepDelegate(QStyledItemDelegate):
    """Draws an item as: badge icon, title on the first line, state below in small grey."""

    def paint(self, painter: QPainter, option: QStyleOptionViewItem, index) -> None:
        opt = QStyleOptionViewItem(option)
        self.initStyleOption(opt, index)
        title, _, state = opt.text.replace("\u2028", "\n").partition("\n")
        icon = QIcon(opt.icon)
        opt.text = ""
        opt.icon = QIcon()
        opt.features &= ~QStyleOptionViewItem.ViewItemFeature.HasDecoration
        widget = opt.widget
        style = widget.style() if widget is not None else None
        if style is not None:
            style.drawControl(QStyle.ControlElement.CE_ItemViewItem, opt, painter, widget)
        painter.save()
        r = opt.rect.adjusted(8, 0, -6, 0)
        size = opt.decorationSize
        icon.paint(painter, QRect(r.left(), r.top() + (r.height() - size.height()) // 2,
                                  size.width(), size.height()))
        text_left = r.left() + size.width() + 10
        title_font = QFont(opt.font)
        state_font = QFont(opt.font)
        state_font.setPointSizeF(max(opt.font.pointSizeF() - 1.5, 7.5))
        width = r.right() - text_left
        title = QFontMetrics(title_font).elidedText(title, Qt.TextElideMode.ElideRight, width)
        mid = r.top() + r.height() // 2
        painter.setFont(title_font)
        painter.setPen(opt.palette.color(opt.palette.ColorRole.Text))
        fg = index.data(Qt.ItemDataRole.ForegroundRole)
        if fg is not None:
            painter.setPen(fg.color())
        painter.drawText(QRect(text_left, r.top(), r.right() - text_left, mid - r.top() + 1),
                         Qt.AlignmentFlag.AlignLeft | Qt.AlignmentFlag.AlignBottom, title)
        painter.setFont(state_font)
        painter.setPen(QColor("#5f6368"))
        painter.drawText(QRect(text_left, mid + 2, r.right() - text_left, r.bottom() - mid - 2),
                         Qt.AlignmentFlag.AlignLeft | Qt.AlignmentFlag.AlignTop, state)
        painter.restore()

    def sizeHint(self, option, index) -> QSize:
        return QSize(option.rect.width(), 52)


class StepList(QListWidget):
    """`set_steps(titles)` once, then `set_state(row, StepState)`; `currentRowChanged(int)`
    tells which step the user picked."""

    def __init__(self, parent: QWidget | None = None):
        super().__init__(parent)
        self.setObjectName("stepList")
        self.setIconSize(QSize(28, 28))
        self.setSelectionMode(QAbstractItemView.SelectionMode.SingleSelection)
        self.setEditTriggers(QAbstractItemView.EditTrigger.NoEditTriggers)
        self.setHorizontalScrollBarPolicy(Qt.ScrollBarPolicy.ScrollBarAlwaysOff)
        self.setSpacing(2)
        self.setUniformItemSizes(True)
        self.setItemDelegate(_StepDelegate(self))
        self._titles: list[str] = []
        self._states: list[StepState] = []

    def set_steps(self, titles: list[str], state: StepState = StepState.TODO) -> None:
        self.clear()
        self._titles = list(titles)
        self._states = [state] * len(titles)
        for row in range(len(titles)):
            item = QListWidgetItem()
            item.setSizeHint(QSize(0, 52))
            self.addItem(item)
            self._refresh(row)

    def set_state(self, row: int, state: StepState) -> None:
        if self._states[row] is not state:
            self._states[row] = state
            self._refresh(row)

    def state(self, row: int) -> StepState:
        return self._states[row]

    def _refresh(self, row: int) -> None:
        item = self.item(row)
        state = self._states[row]
        item.setText(f"{row + 1}. {self._titles[row]}\n{state.value}")
        item.setIcon(state_icon(state, row + 1))
        item.setToolTip(f"Step {row + 1}: {self._titles[row]} ({state.value})")
        item.setForeground(QBrush(QColor("#202124")))
