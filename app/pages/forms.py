"""Small builders for the controls every page has: a labelled spin box, a named button, a row."""
from __future__ import annotations

from typing import Callable

from PySide6.QtCore import QSize, Qt
from PySide6.QtWidgets import (QDoubleSpinBox, QFrame, QHBoxLayout, QLabel, QPushButton, QScrollArea, QSpinBox,
                               QStyle, QWidget)


def button(text: str, name: str = "", *, on_click: Callable[[], object] | None = None,
           tooltip: str = "") -> QPushButton:
    """A push button with an object name (tests find it by name) and a click handler called
    with no arguments."""
    b = QPushButton(text)
    if name:
        b.setObjectName(name)
    if tooltip:
        b.setToolTip(tooltip)
    if on_click is not None:
        b.clicked.connect(lambda *_: on_click())
    return b


def spin(value: int, lo: int, hi: int, *, name: str = "", suffix: str = "", tooltip: str = "",
         step: int = 1) -> QSpinBox:
    """An integer spin box."""
    s = QSpinBox()
    s.setRange(lo, hi)
    s.setValue(value)
    s.setSingleStep(step)
    return _labelled(s, name, suffix, tooltip)


def double_spin(value: float, lo: float, hi: float, *, decimals: int = 2, step: float = 0.1, name: str = "",
                suffix: str = "", tooltip: str = "") -> QDoubleSpinBox:
    """A decimal spin box."""
    s = QDoubleSpinBox()
    s.setDecimals(decimals)
    s.setRange(lo, hi)
    s.setSingleStep(step)
    s.setValue(value)
    return _labelled(s, name, suffix, tooltip)


def _labelled(s, name: str, suffix: str, tooltip: str):
    """The spin box `s` with its object name, unit suffix and tooltip (each when given)."""
    if name:
        s.setObjectName(name)
    if suffix:
        s.setSuffix(suffix)
    if tooltip:
        s.setToolTip(tooltip)
    return s


class WrappedLabel(QLabel):
    """A word-wrapped label whose minimum height is the height its words need at its width. It
    reports no height for width: a box layout would hold it at that height and squeeze the other
    parts of a page below their minimum on a small screen, where the page scrolls instead."""

    def __init__(self, text: str = "", parent: QWidget | None = None):
        super().__init__(text, parent)
        self.setWordWrap(True)

    def hasHeightForWidth(self) -> bool:
        return False

    def minimumSizeHint(self) -> QSize:
        hint = super().minimumSizeHint()
        if self.wordWrap() and self.text() and self.width() > 0:
            hint.setHeight(max(hint.height(), self.heightForWidth(self.width())))
        return hint

    def resizeEvent(self, event) -> None:
        super().resizeEvent(event)
        if event.size().width() != event.oldSize().width():
            self.updateGeometry()          # its words take another number of lines


def scrolling(label: QWidget, *, min_height: int = 0) -> QScrollArea:
    """A text (a wrapped label beside a plot or a table, or a box of wrapping rows) that scrolls up
    and down when its place is shorter than the text, instead of being cut; the label's minimum and
    maximum widths (px) go to the scroll area, with room for its scroll bar."""
    scroll = QScrollArea()
    scroll.setWidgetResizable(True)
    scroll.setFrameShape(QFrame.Shape.NoFrame)
    scroll.setHorizontalScrollBarPolicy(Qt.ScrollBarPolicy.ScrollBarAlwaysOff)
    bar = scroll.style().pixelMetric(QStyle.PixelMetric.PM_ScrollBarExtent) + 2
    if label.minimumWidth() > 0:
        scroll.setMinimumWidth(label.minimumWidth() + bar)
    if label.maximumWidth() < 16777215:
        scroll.setMaximumWidth(label.maximumWidth() + bar)
    if min_height:
        scroll.setMinimumHeight(min_height)
    scroll.setWidget(label)
    return scroll


def row(*items, stretch: bool = True) -> QHBoxLayout:
    """A horizontal row of widgets; a str item becomes a label; a trailing stretch by default."""
    layout = QHBoxLayout()
    layout.setContentsMargins(0, 0, 0, 0)
    for item in items:
        if isinstance(item, str):
            layout.addWidget(QLabel(item))
        elif isinstance(item, QWidget):
            layout.addWidget(item)
        else:
            layout.addLayout(item)
    if stretch:
        layout.addStretch(1)
    return layout
