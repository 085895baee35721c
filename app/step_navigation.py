"""The steps of the wizard and the way through them: the side list of steps (with each step's
state), the current page with its title and summary, Back and Next (gated by the page), and the
step counter."""
from __future__ import annotations

from PySide6.QtCore import QEvent, QObject, Qt, Signal
from PySide6.QtGui import QAction, QKeySequence
from PySide6.QtWidgets import (QApplication, QHBoxLayout, QLabel, QPushButton, QScrollArea, QSplitter,
                               QStackedWidget, QVBoxLayout, QWidget)

from app.explain_dock import ExplainDock
from app.page_holder import scrolled
from app.pages.base import WizardPage
from app.pages.steps import Step
from widgets.step_list import StepList, StepState

#: the step list's narrowest width (px): what a 1280 px screen affords beside a page
STEP_LIST_MIN_WIDTH = 190


class StepNavigation(QObject):
    """`splitter`: the step list beside the page (title, summary, the pages' stack, and a row
    with the step counter, `beside_counter` (the robot's Stop and Resume), Back and Next).
    `action_back` (Alt+Left) and `action_next` (Alt+Right) for the menus. `pageChanged(int)` is
    emitted after a page became current (its Step value)."""

    pageChanged = Signal(int)

    def __init__(self, pages: list[WizardPage], explain: ExplainDock, beside_counter: list[QWidget],
                 parent: QObject):
        super().__init__(parent)
        self.pages = pages
        self.explain = explain
        self.index = -1
        self.action_back = QAction("Back", parent)
        self.action_back.setShortcut(QKeySequence("Alt+Left"))
        self.action_back.triggered.connect(self.back)
        self.action_next = QAction("Next", parent)
        self.action_next.setShortcut(QKeySequence("Alt+Right"))
        self.action_next.triggered.connect(self.next)

        self.step_list = StepList()
        self.step_list.set_steps([p.title for p in pages])
        self.step_list.setMinimumWidth(STEP_LIST_MIN_WIDTH)
        self.step_list.setMaximumWidth(320)
        self.step_list.currentRowChanged.connect(self._row_picked)
        self.page_title = QLabel()
        self.page_title.setObjectName("pageTitle")
        self.page_summary = QLabel()
        self.page_summary.setObjectName("pageSummary")
        self.page_summary.setWordWrap(True)
        self.stack = QStackedWidget()
        for page in pages:
            self.stack.addWidget(scrolled(page))
        self.back_button = QPushButton("◀  Back")
        self.back_button.setObjectName("backButton")
        self.back_button.clicked.connect(self.back)
        self.next_button = QPushButton("Next  ▶")
        self.next_button.setObjectName("nextButton")
        self.next_button.setDefault(True)
        self.next_button.clicked.connect(self.next)
        self.step_counter = QLabel()
        self.step_counter.setObjectName("hint")
        self.splitter = self._splitter(self._content(beside_counter))
        for page in pages:
            page.completeChanged.connect(self.update_states)

    def _content(self, beside_counter: list[QWidget]) -> QWidget:
        nav = QHBoxLayout()
        nav.addWidget(self.step_counter)
        nav.addSpacing(12)
        for widget in beside_counter:
            nav.addWidget(widget)
        nav.addStretch(1)
        nav.addWidget(self.back_button)
        nav.addWidget(self.next_button)
        content = QWidget()
        cl = QVBoxLayout(content)
        cl.setContentsMargins(12, 10, 12, 10)
        cl.setSpacing(6)
        cl.addWidget(self.page_title)
        cl.addWidget(self.page_summary)
        cl.addSpacing(4)
        cl.addWidget(self.stack, 1)
        cl.addLayout(nav)
        return content

    def _splitter(self, content: QWidget) -> QSplitter:
        splitter = QSplitter(Qt.Orientation.Horizontal)
        splitter.addWidget(self.step_list)
        splitter.addWidget(content)
        splitter.setStretchFactor(0, 0)
        splitter.setStretchFactor(1, 1)
        splitter.setSizes([STEP_LIST_MIN_WIDTH + 10, 700])
        splitter.setChildrenCollapsible(False)
        return splitter

    def current_page(self) -> WizardPage:
        return self.pages[self.index]

    @property
    def current_step(self) -> Step:
        return Step(self.index)

    def go_to(self, step: Step | int) -> WizardPage:
        """Leave the current page and enter the page of `step` (its help in the explain panel)."""
        index = int(step)
        if index == self.index:
            return self.pages[index]
        if self.index >= 0:
            self.pages[self.index].on_leave()
        self.index = index
        page = self.pages[index]
        self.stack.setCurrentIndex(index)
        if self.step_list.currentRow() != index:
            self.step_list.blockSignals(True)
            self.step_list.setCurrentRow(index)
            self.step_list.blockSignals(False)
        self.page_title.setText(f"{page.step.number}. {page.title}")
        self.page_summary.setText(page.step.info.summary)
        self.step_counter.setText(f"Step {page.step.number} of {len(self.pages)}")
        self.explain.show_page(page)
        page.on_enter()
        self.update_states()
        self.pageChanged.emit(index)
        return page

    def _row_picked(self, row: int) -> None:
        if 0 <= row < len(self.pages):
            self.go_to(row)

    def can_go_next(self) -> bool:
        return self.index < len(self.pages) - 1 and self.current_page().is_complete()

    def next(self) -> None:
        if self.can_go_next():
            self.go_to(self.index + 1)

    def back(self) -> None:
        if self.index > 0:
            self.go_to(self.index - 1)

    def update_states(self) -> None:
        """Each step's state in the list (error, done, stale, to do); Back and Next enabled as
        the current page allows."""
        for i, page in enumerate(self.pages):
            if page.load_error:
                s = StepState.ERROR
            elif page.is_complete():
                s = StepState.DONE
            else:
                s = StepState.STALE if page.changed_inputs() else StepState.TODO
            self.step_list.set_state(i, s)
        if self.index >= 0:
            ok = self.can_go_next()
            self.next_button.setEnabled(ok)
            self.action_next.setEnabled(ok)
            self.back_button.setEnabled(self.index > 0)
            self.action_back.setEnabled(self.index > 0)
            page = self.current_page()
            if not page.is_complete() and self.index < len(self.pages) - 1:
                self.next_button.setToolTip("Finish this step first")
            else:
                self.next_button.setToolTip("")

    def fit_step_list(self) -> None:
        """The step list just wide enough for its longest title (in its style's font) beside the
        badge, so no title is cut short."""
        self.step_list.ensurePolished()
        metrics = self.step_list.fontMetrics()
        longest = max(metrics.horizontalAdvance(p_title) for p_title in
                      (self.step_list.item(i).text().split("\n")[0] for i in range(self.step_list.count())))
        badge = 28 + 10 + 8 + 6           # the delegate's badge, gap and margins
        frame = 2 * 6 + 2 * 6 + 4         # the list's padding, the item's padding, the frame
        width = max(STEP_LIST_MIN_WIDTH, min(320, longest + badge + frame))
        self.step_list.setMinimumWidth(width)
        self.splitter.setSizes([width, max(1, self.splitter.width() - width)])

    def refit_page(self) -> None:
        """The current page's scroll areas fitted again to their new width (after the explain panel
        took its share, a scroll area could keep a scroll bar from the wider window)."""
        scroll = self.stack.currentWidget()
        if scroll is not None:
            for area in [scroll] + scroll.findChildren(QScrollArea):
                QApplication.postEvent(area, QEvent(QEvent.Type.LayoutRequest))
