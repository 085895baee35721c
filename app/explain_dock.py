"""The explain panel beside the page: the current step's help in a dock on the right, shown or
hidden with F1, taking its share of the window's width."""
from __future__ import annotations

import shiboken6
from PySide6.QtCore import QObject, Qt
from PySide6.QtGui import QAction, QKeySequence
from PySide6.QtWidgets import QDockWidget, QMainWindow, QStyle

from app.pages.base import WizardPage
from core.resources import resource_path
from widgets.explain_panel import ExplainPanel

#: the explain panel's narrowest width (px): what a 1280 px screen affords beside a page
EXPLAIN_MIN_WIDTH = 260


def explain_width(window_width: int) -> int:
    """The explain panel's width for a window this wide (px): 280 at 1280, 520 at 1920, so the
    page keeps most of a small screen."""
    return max(EXPLAIN_MIN_WIDTH, min(560, 280 + int(0.375 * (window_width - 1280))))


class ExplainDock(QObject):
    """`panel` (the help of the current step) in `dock` on the window's right, and `action`
    (View ▸ Explain, F1) that shows or hides it. `sized` once the window was first shown: from
    then on the dock takes its share of the window's width (`take_share()`)."""

    def __init__(self, window: QMainWindow):
        super().__init__(window)
        self.window = window
        self.sized = False
        self.panel = ExplainPanel()
        self.dock = QDockWidget("Explain", window)
        self.dock.setObjectName("explainDock")
        self.dock.setWidget(self.panel)
        self.dock.setFeatures(QDockWidget.DockWidgetFeature.DockWidgetClosable
                              | QDockWidget.DockWidgetFeature.DockWidgetMovable
                              | QDockWidget.DockWidgetFeature.DockWidgetFloatable)
        self.dock.setMinimumWidth(EXPLAIN_MIN_WIDTH)
        window.addDockWidget(Qt.DockWidgetArea.RightDockWidgetArea, self.dock)
        # our own action: the dock's toggleViewAction() would take the dock's changing title
        self.action = QAction("&Explain", window)
        self.action.setCheckable(True)
        self.action.setChecked(True)
        self.action.setShortcut(QKeySequence(Qt.Key.Key_F1))
        self.action.toggled.connect(self.dock.setVisible)
        self.dock.visibilityChanged.connect(self._follow_visibility)
        self.action.setToolTip("Show or hide the explanation of this step (F1)")
        self.action.setIcon(window.style().standardIcon(QStyle.StandardPixmap.SP_MessageBoxQuestion))

    def show_page(self, page: WizardPage) -> None:
        """The page's help, and its title on the dock."""
        self.dock.setWindowTitle(f"Explain: {page.title}")
        self.panel.show_file(resource_path("help", f"{page.help_name}.html"), page.title)

    def take_share(self) -> None:
        """The dock as wide as its share of the window (narrow on a small screen)."""
        self.window.resizeDocks([self.dock], [explain_width(self.window.width())], Qt.Orientation.Horizontal)

    def follow_width(self, width: int, old_width: int) -> None:
        """The window changed from `old_width` to `width` (px): a docked, visible panel takes its
        new share (the user may drag it after)."""
        if self.sized and width != old_width and self.dock.isVisible() and not self.dock.isFloating():
            self.take_share()

    def _follow_visibility(self, visible: bool) -> None:
        # a minimised window hides the dock too: only follow an explicit close; a window being
        # deleted hides it too (nothing to follow)
        window = self.window
        if not shiboken6.isValid(window):
            return
        if not visible and window.isVisible() and not window.isMinimized() and self.dock.isHidden():
            self.action.setChecked(False)
        elif visible:
            self.action.setChecked(True)
            if self.sized and not self.dock.isFloating():
                self.take_share()
