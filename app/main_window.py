"""The wizard's main window: the steps in a side list, one page per step, an explain panel
per page, New/Open/Save, Back/Next, a status bar with progress and Cancel, and Stop."""
from __future__ import annotations

import time
from pathlib import Path

from PySide6.QtCore import QEvent, QObject, QSize, Qt, QTimer, Signal
from PySide6.QtGui import QAction, QCloseEvent, QIcon, QKeyEvent, QKeySequence
from PySide6.QtWidgets import (QApplication, QDockWidget, QFrame, QHBoxLayout, QLabel, QMainWindow, QMenu,
                               QProgressBar, QPushButton, QScrollArea, QSplitter, QStackedWidget, QStyle,
                               QVBoxLayout, QWidget)

from app import project_actions
from app.help_menu import add_help_menu
from app.messages import choose, show_error, show_info
from app.pages.base import WizardPage
from app.pages.registry import create_pages
from app.pages.steps import Step
from app.state import WizardState
from app.worker import TaskHandle, TaskRunner
from core.errors import RoboCalError
from core.resources import resource_path
from widgets.explain_panel import ExplainPanel
from widgets.step_list import StepList, StepState

APP_STYLE = """
QWidget { font-size: 10pt; }
QLabel#pageTitle { font-size: 17pt; font-weight: 600; color: #202124; }
QLabel#pageSummary { font-size: 10.5pt; color: #5f6368; }
QLabel#hint { color: #5f6368; }
QLabel#sectionHeading { font-weight: 600; font-size: 11pt; }
QLabel#loadErrorNotice { font-size: 13pt; font-weight: 600; color: #8a4b00; }
QFrame#loadErrorBox { background: #fef7e0; border: 1px solid #f9d77e; border-radius: 6px; }
QLabel#pageStatus { font-weight: 600; color: #8a4b00; padding: 4px 0; }
QLabel#pageStatus[ok="true"] { color: #188038; }
QListWidget#stepList { font-size: 10.5pt; border: none; background: #f8f9fa; padding: 6px; }
QListWidget#stepList::item { padding: 4px 6px; border-radius: 6px; color: #202124; }
QListWidget#stepList::item:selected { background: #d2e3fc; color: #202124; }
QGroupBox { font-weight: 600; margin-top: 14px; }
QGroupBox::title { subcontrol-origin: margin; left: 8px; padding: 0 4px; }
QPushButton#nextButton { font-weight: 600; }
"""

#: the step list's and the explain panel's narrowest widths (px): what a 1280 px screen affords
#: beside a page
STEP_LIST_MIN_WIDTH = 190
EXPLAIN_MIN_WIDTH = 260


def explain_width(window_width: int) -> int:
    """The explain panel's width for a window this wide (px): 280 at 1280, 520 at 1920, so the
    page keeps most of a small screen."""
    return max(EXPLAIN_MIN_WIDTH, min(560, 280 + int(0.375 * (window_width - 1280))))


class _StopKeyWhileModal(QObject):
    """The window's Stop shortcuts act while the main window has the keyboard. Elsewhere — a
    modal or file dialog, a menu, another window of RoboCal, where Qt blocks the window's
    shortcuts — Ctrl+. still stops the robot, and Esc does only while a motion is running: there
    Esc first means "close this dialog", and stopping a robot that stands still would be a
    surprise. The dialog or menu gets the key too."""

    def __init__(self, window: "MainWindow"):
        super().__init__(window)
        self.window = window
        self._last = (None, 0.0)

    def eventFilter(self, obj, event) -> bool:
        if event.type() != QEvent.Type.KeyPress or not isinstance(event, QKeyEvent) or event.isAutoRepeat():
            return False
        elsewhere = (QApplication.activeModalWidget() is not None
                     or isinstance(QApplication.activePopupWidget(), QMenu)    # menus eat Esc too
                     or QApplication.activeWindow() is not self.window)
        if elsewhere:
            key, mods = event.key(), event.modifiers() & ~Qt.KeyboardModifier.KeypadModifier
            if ((key == Qt.Key.Key_Escape and mods == Qt.KeyboardModifier.NoModifier and self.window.motion_running())
                    or (key == Qt.Key.Key_Period and mods == Qt.KeyboardModifier.ControlModifier)):
                # an unhandled key press travels up from its receiver to the dialog, passing
                # this filter at each step: act on the first step only
                now = time.monotonic()
                last_obj, last_time = self._last
                propagating = (last_obj is not None and now - last_time < 0.05
                               and isinstance(obj, QWidget) and isinstance(last_obj, QWidget)
                               and obj.isAncestorOf(last_obj))
                self._last = (obj, now)
                if not propagating:
                    self.window.stop_robot()
        return False


class _PageHolder(QWidget):
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


def app_icon() -> QIcon:
    return QIcon(str(resource_path("icons", "robocal.svg")))


class MainWindow(QMainWindow):
    """`pageChanged(int)` is emitted after a page became current (its Step value)."""

    pageChanged = Signal(int)

    def __init__(self, state: WizardState | None = None, parent: QWidget | None = None):
        super().__init__(parent)
        self.state = state if state is not None else WizardState(self)
        self.tasks = TaskRunner(self)
        self.setWindowIcon(app_icon())
        self.setObjectName("mainWindow")
        self.setStyleSheet(APP_STYLE)

        self.pages: list[WizardPage] = create_pages(self.state, self.tasks)
        self._build_actions()
        self._build_central()
        self._build_explain_dock()
        self._build_menus_and_toolbar()
        self._build_status_bar()

        for page in self.pages:
            page.completeChanged.connect(self._update_states)
        self.state.projectChanged.connect(self._update_title)
        self.state.robotChanged.connect(self._update_mode_label)
        self.state.hardware.connectionChanged.connect(self._update_mode_label)
        self.state.hardware.stoppedChanged.connect(self._update_mode_label)
        self.tasks.progress.connect(self._on_progress)
        self.tasks.busyChanged.connect(self._on_busy)
        self.tasks.unhandledError.connect(lambda msg, label: show_error(self, msg, f"RoboCal: {label}"))

        self._current = -1
        self.resize(1400, 900)
        self._update_states()
        self._update_title()
        self._update_mode_label()
        self.go_to(Step.SETUP)

    # -- construction --------------------------------------------------------------------
    def _build_actions(self) -> None:
        style = self.style()
        self.action_new = QAction(style.standardIcon(QStyle.StandardPixmap.SP_FileIcon), "&New project…", self)
        self.action_new.setShortcut(QKeySequence.StandardKey.New)
        self.action_new.triggered.connect(lambda: project_actions.new_project(self, self.state))
        self.action_open = QAction(style.standardIcon(QStyle.StandardPixmap.SP_DirOpenIcon), "&Open project…", self)
        self.action_open.setShortcut(QKeySequence.StandardKey.Open)
        self.action_open.triggered.connect(lambda: project_actions.open_project(self, self.state))
        self.action_save = QAction(style.standardIcon(QStyle.StandardPixmap.SP_DialogSaveButton), "&Save", self)
        self.action_save.setShortcut(QKeySequence.StandardKey.Save)
        self.action_save.triggered.connect(self.save_project)
        self.action_save_demo = QAction("Save the demo as a project…", self)
        self.action_save_demo.triggered.connect(lambda: project_actions.save_demo_as_project(self, self.state))
        self.action_quit = QAction("&Quit", self)
        self.action_quit.setShortcut(QKeySequence.StandardKey.Quit)
        self.action_quit.setMenuRole(QAction.MenuRole.QuitRole)
        self.action_quit.triggered.connect(self.close)

        # Robot safety: Stop is always one key away, whatever has the focus.
        self.action_stop = QAction(style.standardIcon(QStyle.StandardPixmap.SP_BrowserStop), "&Stop robot", self)
        self.action_stop.setShortcuts([QKeySequence(Qt.Key.Key_Escape), QKeySequence("Ctrl+.")])
        self.action_stop.setShortcutContext(Qt.ShortcutContext.WindowShortcut)   # other windows: _StopKeyWhileModal
        self.action_stop.setToolTip("Stop the robot now and cancel the running task (Esc or Ctrl+.; in a dialog, "
                                    "Ctrl+., and Esc while the robot moves)")
        self.action_stop.triggered.connect(self.stop_robot)
        self.action_resume = QAction("&Resume after stop", self)
        self.action_resume.triggered.connect(self.resume_robot)

        self.action_back = QAction("Back", self)
        self.action_back.setShortcut(QKeySequence("Alt+Left"))
        self.action_back.triggered.connect(self.back)
        self.action_next = QAction("Next", self)
        self.action_next.setShortcut(QKeySequence("Alt+Right"))
        self.action_next.triggered.connect(self.next)
        self.action_about = QAction("&About RoboCal", self)
        self.action_about.triggered.connect(self._about)
        for a in (self.action_back, self.action_next, self.action_stop):
            self.addAction(a)   # shortcuts work even when the toolbar is hidden
        self._modal_stop = _StopKeyWhileModal(self)
        QApplication.instance().installEventFilter(self._modal_stop)

    def _build_central(self) -> None:
        self.step_list = StepList()
        self.step_list.set_steps([p.title for p in self.pages])
        self.step_list.setMinimumWidth(STEP_LIST_MIN_WIDTH)
        self.step_list.setMaximumWidth(320)
        self.step_list.currentRowChanged.connect(self._row_picked)

        self.page_title = QLabel()
        self.page_title.setObjectName("pageTitle")
        self.page_summary = QLabel()
        self.page_summary.setObjectName("pageSummary")
        self.page_summary.setWordWrap(True)
        self.stack = QStackedWidget()
        for page in self.pages:
            self.stack.addWidget(self._scrolled(page))

        self.back_button = QPushButton("◀  Back")
        self.back_button.setObjectName("backButton")
        self.back_button.clicked.connect(self.back)
        self.next_button = QPushButton("Next  ▶")
        self.next_button.setObjectName("nextButton")
        self.next_button.setDefault(True)
        self.next_button.clicked.connect(self.next)
        self.step_counter = QLabel()
        self.step_counter.setObjectName("hint")
        # a real robot connected: Stop is a big red button on every page (and Esc)
        self.stop_button = QPushButton("■  Stop robot (Esc)")
        self.stop_button.setObjectName("stopRobotButton")
        self.stop_button.setStyleSheet("QPushButton { color: white; background: #c5221f; font-weight: 600; "
                                       "padding: 4px 14px; }")
        self.stop_button.setToolTip("Stop the robot now and cancel the running task (Esc or Ctrl+.)")
        self.stop_button.clicked.connect(self.stop_robot)
        self.resume_button = QPushButton("Resume robot")
        self.resume_button.setObjectName("resumeRobotButton")
        self.resume_button.setToolTip("Accept motion again after a stop, once the way is clear")
        self.resume_button.clicked.connect(self.resume_robot)
        nav = QHBoxLayout()
        nav.addWidget(self.step_counter)
        nav.addSpacing(12)
        nav.addWidget(self.stop_button)
        nav.addWidget(self.resume_button)
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

        self.splitter = QSplitter(Qt.Orientation.Horizontal)
        self.splitter.addWidget(self.step_list)
        self.splitter.addWidget(content)
        self.splitter.setStretchFactor(0, 0)
        self.splitter.setStretchFactor(1, 1)
        self.splitter.setSizes([STEP_LIST_MIN_WIDTH + 10, 700])
        self.splitter.setChildrenCollapsible(False)
        self.setCentralWidget(self.splitter)

    @staticmethod
    def _scrolled(page: WizardPage) -> QScrollArea:
        """The page in a scroll area: a page taller (or wider) than a small screen scrolls
        instead of growing the window beyond the screen."""
        scroll = QScrollArea()
        scroll.setObjectName(f"scroll_{page.step.slug}")
        scroll.setWidgetResizable(True)
        scroll.setFrameShape(QFrame.Shape.NoFrame)
        scroll.setWidget(_PageHolder(page))
        return scroll

    def _build_explain_dock(self) -> None:
        self.explain = ExplainPanel()
        self.explain_dock = QDockWidget("Explain", self)
        self.explain_dock.setObjectName("explainDock")
        self.explain_dock.setWidget(self.explain)
        self.explain_dock.setFeatures(QDockWidget.DockWidgetFeature.DockWidgetClosable
                                      | QDockWidget.DockWidgetFeature.DockWidgetMovable
                                      | QDockWidget.DockWidgetFeature.DockWidgetFloatable)
        self.explain_dock.setMinimumWidth(EXPLAIN_MIN_WIDTH)
        self.addDockWidget(Qt.DockWidgetArea.RightDockWidgetArea, self.explain_dock)
        # our own action: the dock's toggleViewAction() would take the dock's changing title
        self.action_explain = QAction("&Explain", self)
        self.action_explain.setCheckable(True)
        self.action_explain.setChecked(True)
        self.action_explain.setShortcut(QKeySequence(Qt.Key.Key_F1))
        self.action_explain.toggled.connect(self.explain_dock.setVisible)
        self.explain_dock.visibilityChanged.connect(self._explain_visibility)
        self.action_explain.setToolTip("Show or hide the explanation of this step (F1)")
        self.action_explain.setIcon(self.style().standardIcon(QStyle.StandardPixmap.SP_MessageBoxQuestion))

    def _explain_visibility(self, visible: bool) -> None:
        # a minimised window hides the dock too: only follow an explicit close
        if not visible and self.isVisible() and not self.isMinimized() and self.explain_dock.isHidden():
            self.action_explain.setChecked(False)
        elif visible:
            self.action_explain.setChecked(True)
            if getattr(self, "_docks_sized", False) and not self.explain_dock.isFloating():
                self.resizeDocks([self.explain_dock], [explain_width(self.width())], Qt.Orientation.Horizontal)

    def _build_menus_and_toolbar(self) -> None:
        menu = self.menuBar()
        file_menu = menu.addMenu("&File")
        for a in (self.action_new, self.action_open, self.action_save, self.action_save_demo):
            file_menu.addAction(a)
        file_menu.addSeparator()
        file_menu.addAction(self.action_quit)
        robot_menu = menu.addMenu("&Robot")
        robot_menu.addAction(self.action_stop)
        robot_menu.addAction(self.action_resume)
        go_menu = menu.addMenu("&Go")
        go_menu.addAction(self.action_back)
        go_menu.addAction(self.action_next)
        view_menu = menu.addMenu("&View")
        view_menu.addAction(self.action_explain)
        help_menu = menu.addMenu("&Help")
        add_help_menu(self, help_menu, self.action_about,
                      [self.action_new, self.action_open, self.action_save, self.action_quit, self.action_stop,
                       self.action_back, self.action_next, self.action_explain])

        bar = self.addToolBar("Main")
        bar.setObjectName("mainToolBar")
        bar.setMovable(False)
        bar.setIconSize(QSize(20, 20))
        bar.setToolButtonStyle(Qt.ToolButtonStyle.ToolButtonTextBesideIcon)
        for a in (self.action_new, self.action_open, self.action_save):
            bar.addAction(a)
        bar.addSeparator()
        bar.addAction(self.action_stop)
        bar.addSeparator()
        bar.addAction(self.action_explain)

    def _build_status_bar(self) -> None:
        bar = self.statusBar()
        self.progress_bar = QProgressBar()
        self.progress_bar.setRange(0, 1000)
        self.progress_bar.setMinimumWidth(240)
        self.progress_bar.setTextVisible(True)
        self.cancel_button = QPushButton("Cancel")
        self.cancel_button.setToolTip("Cancel the running task")
        self.cancel_button.clicked.connect(self.cancel_tasks)
        self.mode_label = QLabel()
        self.mode_label.setObjectName("hint")
        bar.addPermanentWidget(self.progress_bar)
        bar.addPermanentWidget(self.cancel_button)
        bar.addPermanentWidget(self.mode_label)
        self.progress_bar.hide()
        self.cancel_button.hide()

    def showEvent(self, event) -> None:
        super().showEvent(event)
        if not getattr(self, "_docks_sized", False):
            self._docks_sized = True
            self._fit_step_list()
            # the first layout gives the dock its minimum: widen it to its share of the window
            self.resizeDocks([self.explain_dock], [explain_width(self.width())], Qt.Orientation.Horizontal)

    def _fit_step_list(self) -> None:
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

    def resizeEvent(self, event) -> None:
        super().resizeEvent(event)
        # the explain panel takes its share of a window that changed width: narrow beside the page
        # on a small screen, wider on a large one (the user may drag it after)
        if (getattr(self, "_docks_sized", False) and event.size().width() != event.oldSize().width()
                and self.explain_dock.isVisible() and not self.explain_dock.isFloating()):
            self.resizeDocks([self.explain_dock], [explain_width(self.width())], Qt.Orientation.Horizontal)
        for delay in (0, 100):          # once the explain panel took its share too
            QTimer.singleShot(delay, self, self._refit_page)

    def _refit_page(self) -> None:
        """The current page's scroll areas fitted again to their new width (after the explain panel
        took its share, a scroll area could keep a scroll bar from the wider window)."""
        scroll = self.stack.currentWidget()
        if scroll is not None:
            for area in [scroll] + scroll.findChildren(QScrollArea):
                QApplication.postEvent(area, QEvent(QEvent.Type.LayoutRequest))

    # -- navigation ----------------------------------------------------------------------
    def page(self, step: Step | int) -> WizardPage:
        return self.pages[int(step)]

    def current_page(self) -> WizardPage:
        return self.pages[self._current]

    @property
    def current_step(self) -> Step:
        return Step(self._current)

    def go_to(self, step: Step | int) -> WizardPage:
        index = int(step)
        if index == self._current:
            return self.pages[index]
        if self._current >= 0:
            self.pages[self._current].on_leave()
        self._current = index
        page = self.pages[index]
        self.stack.setCurrentIndex(index)
        if self.step_list.currentRow() != index:
            self.step_list.blockSignals(True)
            self.step_list.setCurrentRow(index)
            self.step_list.blockSignals(False)
        self.page_title.setText(f"{page.step.number}. {page.title}")
        self.page_summary.setText(page.step.info.summary)
        self.step_counter.setText(f"Step {page.step.number} of {len(self.pages)}")
        self.explain_dock.setWindowTitle(f"Explain: {page.title}")
        self.explain.show_file(resource_path("help", f"{page.help_name}.html"), page.title)
        page.on_enter()
        self._update_states()
        self.pageChanged.emit(index)
        return page

    def _row_picked(self, row: int) -> None:
        if 0 <= row < len(self.pages):
            self.go_to(row)

    def can_go_next(self) -> bool:
        page = self.current_page()
        return self._current < len(self.pages) - 1 and page.is_complete()

    def next(self) -> None:
        if self.can_go_next():
            self.go_to(self._current + 1)

    def back(self) -> None:
        if self._current > 0:
            self.go_to(self._current - 1)

    def _update_states(self) -> None:
        for i, page in enumerate(self.pages):
            if page.load_error:
                s = StepState.ERROR
            elif page.is_complete():
                s = StepState.DONE
            else:
                s = StepState.STALE if page.changed_inputs() else StepState.TODO
            self.step_list.set_state(i, s)
        if self._current >= 0:
            ok = self.can_go_next()
            self.next_button.setEnabled(ok)
            self.action_next.setEnabled(ok)
            self.back_button.setEnabled(self._current > 0)
            self.action_back.setEnabled(self._current > 0)
            page = self.current_page()
            if not page.is_complete() and self._current < len(self.pages) - 1:
                self.next_button.setToolTip("Finish this step first")
            else:
                self.next_button.setToolTip("")

    # -- project -------------------------------------------------------------------------
    def save_project(self) -> bool:
        ok = project_actions.save_project(self, self.state)
        if ok:
            self.statusBar().showMessage(f"Saved {self.state.project.folder}", 5000)
        return ok

    def _update_title(self, *_):
        project = self.state.project
        name = project.name if project is not None else "no project"
        demo = " (temporary demo)" if self.state.is_temporary() else ""
        self.setWindowTitle(f"RoboCal — {name}{demo}")
        self.action_save_demo.setVisible(self.state.is_temporary())

    def _update_mode_label(self, *_):
        conn = self.state.hardware.robot_connection
        mode = "Virtual lab" if self.state.virtual else "Hardware"
        robot = "no robot" if conn is None else ("robot stopped" if conn.stopped else "robot ready")
        if self.state.hardware.real_robot:
            robot = f"{conn.name} · {robot}"
        self.mode_label.setText(f"  {mode} · {robot}  ")
        self.stop_button.setVisible(self.state.hardware.real_robot)
        self.resume_button.setVisible(conn is not None and conn.stopped)

    # -- robot safety --------------------------------------------------------------------
    def motion_running(self) -> bool:
        """A robot is connected and ready, and a task runs that may be moving it."""
        conn = self.state.hardware.robot_connection
        return conn is not None and not conn.stopped and self.tasks.busy

    def stop_robot(self) -> None:
        """Stop the robot (if any) and cancel the running tasks: one key, always."""
        stopped = self.state.hardware.stop_robot()
        busy = self.tasks.busy
        self.tasks.cancel_all()
        if stopped:
            self.statusBar().showMessage("Robot stopped. Robot ▸ Resume after stop when the way is clear.")
        elif busy:
            self.statusBar().showMessage("Stop: the running task was cancelled (no robot connected).", 5000)
        else:
            self.statusBar().showMessage("Stop: no robot connected.", 3000)
        self._update_mode_label()

    def resume_robot(self) -> None:
        """Accept motion again after a stop (the technician checked that the way is clear)."""
        try:
            if self.state.hardware.resume_robot():
                self.statusBar().showMessage("Robot ready.", 3000)
        except RoboCalError as exc:
            show_error(self, f"The robot cannot resume: {exc.message}", "RoboCal: robot")
        self._update_mode_label()

    # -- tasks ---------------------------------------------------------------------------
    def run_task(self, fn, *args, on_result=None, on_error=None, on_cancelled=None,
                 on_progress=None, label: str = "Working", **kwargs) -> TaskHandle:
        """Run a core function on a worker thread with progress and Cancel in the status bar."""
        return self.tasks.start(fn, *args, on_result=on_result, on_error=on_error,
                                on_cancelled=on_cancelled, on_progress=on_progress, label=label, **kwargs)

    def cancel_tasks(self) -> None:
        self.tasks.cancel_all()
        self.progress_bar.setFormat("Cancelling…")

    def _on_progress(self, fraction: float, message: str, label: str) -> None:
        self.progress_bar.setValue(int(round(1000 * min(max(fraction, 0.0), 1.0))))
        text = f"{label}: {message}" if message else label
        self.progress_bar.setFormat(f"{text.replace('%', '%%')}  %p%")
        # wide enough for its words (on one line), up to half the window; the rest in the tooltip
        needed = self.progress_bar.fontMetrics().horizontalAdvance(f"{text}  100%") + 24
        self.progress_bar.setMinimumWidth(max(240, min(needed, self.width() // 2)))
        self.progress_bar.setToolTip(text)

    def _on_busy(self, busy: bool) -> None:
        self.progress_bar.setVisible(busy)
        self.cancel_button.setVisible(busy)
        if busy:
            self.progress_bar.setValue(0)
        else:
            self.progress_bar.setFormat("%p%")

    # -- misc ----------------------------------------------------------------------------
    def save_screenshot(self, path: str | Path) -> Path:
        """The whole window as a PNG, written atomically (RoboCalError if it cannot be)."""
        from PySide6.QtCore import QBuffer, QByteArray, QIODevice

        from core.files import atomic_write_bytes

        data = QByteArray()
        buffer = QBuffer(data)
        buffer.open(QIODevice.OpenModeFlag.WriteOnly)
        if not self.grab().save(buffer, "PNG"):
            raise RoboCalError("cannot encode the screenshot", source=path)
        return atomic_write_bytes(path, bytes(data))

    def _about(self) -> None:
        show_info(self, "RoboCal makes a robot arm more accurate with two ordinary cameras: "
                        "stereo calibration, marker detection, pose selection, measurement and "
                        "kinematic identification, with a built-in virtual lab.", "About RoboCal")

    def _demo_may_close(self) -> bool:
        """A demo with results is kept only if saved: ask (False: the user cancelled)."""
        if not project_actions.demo_has_results(self.state):
            return True
        save, discard = "Save the demo as a project…", "Quit without saving"
        answer = choose(self, "The demo's images, results, exports and report are in a temporary folder that is "
                              "deleted when RoboCal quits. Save them as a project first?",
                        [save, discard], "RoboCal: quit", non_interactive_answer=discard)
        if answer == save:
            return project_actions.save_demo_as_project(self, self.state) is not None
        return answer == discard

    def closeEvent(self, event: QCloseEvent) -> None:
        if not self._demo_may_close():
            event.ignore()
            return
        QApplication.instance().removeEventFilter(self._modal_stop)
        self.state.hardware.stop_robot()
        self.tasks.shutdown()
        self.state.close()
        super().closeEvent(event)
