"""The wizard's main window: the steps in a side list, one page per step, an explain panel
per page, New/Open/Save, Back/Next, a status bar with progress and Cancel, and Stop.

The window composes its parts, each with its own state: `navigation` (app/step_navigation.py),
`explainer` (app/explain_dock.py), `project` (app/project_menu.py), `status`
(app/window_status_bar.py) and `robot_stop` (app/robot_stop.py)."""
from __future__ import annotations

from pathlib import Path

from PySide6.QtCore import QSize, Qt, QTimer, Signal
from PySide6.QtGui import QAction, QCloseEvent, QIcon, QKeySequence
from PySide6.QtWidgets import QMainWindow, QWidget

from app.explain_dock import ExplainDock
from app.help_menu import add_help_menu
from app.messages import show_error, show_info
from app.pages.base import WizardPage
from app.pages.registry import create_pages
from app.pages.steps import Step
from app.project_menu import ProjectMenu
from app.robot_stop import RobotStop
from app.state import WizardState
from app.step_navigation import StepNavigation
from app.window_status_bar import WindowStatusBar
from app.worker import TaskHandle, TaskRunner
from core.errors import RoboCalError
from core.resources import resource_path

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


def app_icon() -> QIcon:
    return QIcon(str(resource_path("icons", "robocal.svg")))


class MainWindow(QMainWindow):
    """`pageChanged(int)` is emitted after a page became current (its Step value). The parts'
    widgets and actions are reachable on the window by name too (`step_list`, `stack`,
    `next_button`, `stop_button`, `progress_bar`, `explain_dock`, `action_stop`...)."""

    pageChanged = Signal(int)

    def __init__(self, state: WizardState | None = None, parent: QWidget | None = None):
        super().__init__(parent)
        self.state = state if state is not None else WizardState(self)
        self.tasks = TaskRunner(self)
        self.setWindowIcon(app_icon())
        self.setObjectName("mainWindow")
        self.setStyleSheet(APP_STYLE)

        self.pages: list[WizardPage] = create_pages(self.state, self.tasks)
        self.project = ProjectMenu(self, self.state)
        self.status = WindowStatusBar(self, self.state, self.tasks)
        self.robot_stop = RobotStop(self, self.state, self.tasks, self.status)
        self.explainer = ExplainDock(self)
        self.navigation = StepNavigation(self.pages, self.explainer,
                                         [self.robot_stop.stop_button, self.robot_stop.resume_button], self)
        self.navigation.pageChanged.connect(self.pageChanged)
        self.setCentralWidget(self.navigation.splitter)
        self._name_parts()
        self.action_quit = QAction("&Quit", self)
        self.action_quit.setShortcut(QKeySequence.StandardKey.Quit)
        self.action_quit.setMenuRole(QAction.MenuRole.QuitRole)
        self.action_quit.triggered.connect(self.close)
        self.action_about = QAction("&About RoboCal", self)
        self.action_about.triggered.connect(self._about)
        for a in (self.action_back, self.action_next, self.action_stop):
            self.addAction(a)   # shortcuts work even when the toolbar is hidden
        self._build_menus_and_toolbar()
        self.tasks.unhandledError.connect(lambda msg, label: show_error(self, msg, f"RoboCal: {label}"))

        self.resize(1400, 900)
        self.navigation.update_states()
        self.project.show_title()
        self.robot_stop.show_state()
        self.go_to(Step.SETUP)

    def _name_parts(self) -> None:
        """The parts' widgets and actions under the window's names for them."""
        nav, stop, status, project = self.navigation, self.robot_stop, self.status, self.project
        self.step_list, self.stack, self.splitter = nav.step_list, nav.stack, nav.splitter
        self.page_title, self.page_summary, self.step_counter = nav.page_title, nav.page_summary, nav.step_counter
        self.back_button, self.next_button = nav.back_button, nav.next_button
        self.action_back, self.action_next = nav.action_back, nav.action_next
        self.stop_button, self.resume_button = stop.stop_button, stop.resume_button
        self.action_stop, self.action_resume = stop.action_stop, stop.action_resume
        self.progress_bar, self.cancel_button, self.mode_label = (status.progress_bar, status.cancel_button,
                                                                  status.mode_label)
        self.explain, self.explain_dock, self.action_explain = (self.explainer.panel, self.explainer.dock,
                                                                self.explainer.action)
        self.action_new, self.action_open = project.action_new, project.action_open
        self.action_save, self.action_save_demo = project.action_save, project.action_save_demo

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

    def showEvent(self, event) -> None:
        super().showEvent(event)
        if not self.explainer.sized:
            self.explainer.sized = True
            self.navigation.fit_step_list()
            # the first layout gives the dock its minimum: widen it to its share of the window
            self.explainer.take_share()

    def resizeEvent(self, event) -> None:
        super().resizeEvent(event)
        # the explain panel takes its share of a window that changed width: narrow beside the page
        # on a small screen, wider on a large one (the user may drag it after)
        self.explainer.follow_width(event.size().width(), event.oldSize().width())
        for delay in (0, 100):          # once the explain panel took its share too
            QTimer.singleShot(delay, self.navigation, self.navigation.refit_page)

    # -- navigation (StepNavigation) -----------------------------------------------------
    def page(self, step: Step | int) -> WizardPage:
        return self.pages[int(step)]

    def current_page(self) -> WizardPage:
        return self.navigation.current_page()

    @property
    def current_step(self) -> Step:
        return self.navigation.current_step

    def go_to(self, step: Step | int) -> WizardPage:
        return self.navigation.go_to(step)

    def can_go_next(self) -> bool:
        return self.navigation.can_go_next()

    def next(self) -> None:
        self.navigation.next()

    def back(self) -> None:
        self.navigation.back()

    # -- robot safety (RobotStop) --------------------------------------------------------
    def motion_running(self) -> bool:
        """A robot is connected and ready, and a task runs that may be moving it."""
        return self.robot_stop.motion_running()

    def stop_robot(self) -> None:
        """Stop the robot (if any) and cancel the running tasks: one key, always."""
        self.robot_stop.stop()

    def resume_robot(self) -> None:
        """Accept motion again after a stop (the technician checked that the way is clear)."""
        self.robot_stop.resume()

    # -- tasks, screenshots, closing -----------------------------------------------------
    def run_task(self, fn, *args, on_result=None, on_error=None, on_cancelled=None,
                 on_progress=None, label: str = "Working", **kwargs) -> TaskHandle:
        """Run a core function on a worker thread with progress and Cancel in the status bar."""
        return self.tasks.start(fn, *args, on_result=on_result, on_error=on_error,
                                on_cancelled=on_cancelled, on_progress=on_progress, label=label, **kwargs)

    def save_screenshot(self, path: str | Path) -> Path:
        """The whole window as a PNG, written atomically (RoboCalError if it cannot be)."""
        from core.files import atomic_write_bytes
        from widgets.png import png_bytes

        data = png_bytes(self.grab().toImage())
        if not data:
            raise RoboCalError("cannot encode the screenshot", source=path)
        return atomic_write_bytes(path, data)

    def _about(self) -> None:
        show_info(self, "RoboCal makes a robot arm more accurate with two ordinary cameras: "
                        "stereo calibration, marker detection, pose selection, measurement and "
                        "kinematic identification, with a built-in virtual lab.", "About RoboCal")

    def closeEvent(self, event: QCloseEvent) -> None:
        if not self.project.demo_may_close():
            event.ignore()
            return
        self.robot_stop.shut_down()
        self.tasks.shutdown()
        self.state.close()
        super().closeEvent(event)
