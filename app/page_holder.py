"""A wizard page in its scroll area, filling the area: the area scrolls only when the page is
smaller than its minimum size."""
from __future__ import annotations

from PySide6.QtCore import QEvent, QSize
from PySide6.QtWidgets import QApplication, QFrame, QScrollArea, QWidget

from app.pages.base import WizardPage


class PageHolder(QWidget):
    """Holds a page in its scroll area and fills the area with it. The area scrolls only when
    the page is smaller than its minimum size (its plots and tables squeezed to their minimum),
    not as soon as it is smaller than its preferred height, as a page with wrapping labels
    (height for width) in a resizable scroll area would."""

    def __init__(self, page: QWidget):
        super().__init__()
        self.page = page
        page.setParent(self)

    def minimumSizeHint(self) -> QSize:
        return self.page.minimumSizeHint().expandedTo(self.page.minimumSize())

    def sizeHint(self) -> QSize:
        return self.page.sizeHint()

    def resizeEvent(self, event) -> None:
        self.page.setGeometry(self.rect())

    def event(self, event) -> bool:
        if event.type() == QEvent.Type.LayoutRequest:     # the page's size hints changed
            self.updateGeometry()
            scroll = self.parentWidget().parentWidget() if self.parentWidget() is not None else None
            if isinstance(scroll, QScrollArea):
                QApplication.postEvent(scroll, QEvent(QEvent.Type.LayoutRequest))
        return super().event(event)


def scrolled(page: WizardPage) -> QScrollArea:
    """The page in a scroll area: a page taller (or wider) than a small screen scrolls
    instead of growing the window beyond the screen."""
    scroll = QScrollArea()
    scroll.setObjectName(f"scroll_{page.step.slug}")
    scroll.setWidgetResizable(True)
    scroll.setFrameShape(QFrame.Shape.NoFrame)
    scroll.setWidget(PageHolder(page))
    return scroll
