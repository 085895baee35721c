"""`robocal gui [--demo] [--autopilot] [--screenshots DIR] [PROJECT]`: open the wizard.

--demo        start on the virtual lab with a temporary project and the educational 6R arm
--autopilot   run every page on its own, in order, and exit (0 when all finished, 1 if not)
--screenshots save DIR/NN-<step>.png of the whole window for every page shown
PROJECT       a project folder to open (with --demo, created there if it is not a project, and kept:
              `robocal report PROJECT` makes the demo's report afterwards); also --project PROJECT

Qt is imported only when the command runs, so the other subcommands never load it. Before a
window on a display server (xcb, wayland) is tried, app/qt_libs.py checks the system libraries
and the display, so a missing one is named with its package instead of Qt's own abort.
"""
from __future__ import annotations

import sys
from pathlib import Path

from app.commands import CommandResult
from core.errors import RoboCalError, UsageError
from core.project import PROJECT_FILE, open_project

HELP = "Open the wizard (--demo: on the virtual lab; --autopilot: run every page on its own)"


def add_arguments(parser) -> None:
    parser.add_argument("project", nargs="?", metavar="PROJECT", help="project folder to open")
    parser.add_argument("--project", dest="project_option", metavar="DIR",
                        help="the same as PROJECT; with --demo the demo runs in DIR and is kept there")
    parser.add_argument("--demo", action="store_true",
                        help="start on the virtual lab with a temporary project and the educational 6R arm")
    parser.add_argument("--autopilot", action="store_true",
                        help="run every page on its own in order and exit (0 when all finished)")
    parser.add_argument("--screenshots", metavar="DIR",
                        help="save DIR/NN-<step>.png of the window for every page shown")


def _opens_existing_project(args) -> bool:
    """PROJECT names a project to open (with --demo, only one whose project file is there already;
    otherwise the demo creates it)."""
    return bool(args.project) and (not args.demo or (Path(args.project) / PROJECT_FILE).exists())


def prepare_state(state, args) -> None:
    """Open or create the project `args` names (PROJECT, --demo) in `state`, the demo arm chosen for --demo."""
    from app.pages.setup.page import DEMO_PRESET

    if args.project:
        folder = Path(args.project)
        if _opens_existing_project(args):
            state.open_project(folder)
        else:
            state.new_project(folder)
        if args.demo and state.robot is None:
            state.choose_preset(DEMO_PRESET)
    elif args.demo:
        state.temporary_project()
        state.choose_preset(DEMO_PRESET)


def run(args) -> CommandResult:
    if args.project_option:
        if args.project and args.project != args.project_option:
            raise UsageError("give the project folder once, as PROJECT or as --project")
        args.project = args.project_option
    screenshots = Path(args.screenshots) if args.screenshots else None
    if screenshots is not None:
        from core.files import ensure_writable_dir
        ensure_writable_dir(screenshots)
    if args.project and not args.demo and not Path(args.project).exists():
        raise UsageError(f"no such project folder: {args.project}")
    if _opens_existing_project(args):
        open_project(args.project)      # a project file that cannot be read is said before Qt loads

    from app.qt_libs import DISPLAY_PLATFORMS, check_qt_libraries, platform_in_use
    if platform_in_use() in DISPLAY_PLATFORMS:       # Qt would abort with its own words: say what to do first
        libraries = check_qt_libraries()
        if not libraries.ok:
            raise libraries.error()

    from PySide6.QtCore import QTimer
    from PySide6.QtWidgets import QApplication

    from app import messages
    from app.main_window import MainWindow, app_icon
    from app.state import WizardState

    app = QApplication.instance() or QApplication(sys.argv[:1])
    app.setApplicationName("RoboCal")
    app.setOrganizationName("RoboCal")
    app.setDesktopFileName("robocal")
    app.setStyle("Fusion")
    app.setWindowIcon(app_icon())

    messages.set_non_interactive(args.autopilot)
    state = WizardState()
    try:
        prepare_state(state, args)
    except RoboCalError:
        state.close()
        messages.set_non_interactive(False)
        raise

    window = MainWindow(state)
    fatal: list[BaseException] = []

    def on_fatal(exc):
        fatal.append(exc)
        app.exit(1)

    restore_hook = messages.install_excepthook(lambda: window, on_fatal)
    autopilot = None
    try:
        window.show()
        if args.autopilot:
            from app.autopilot import Autopilot
            autopilot = Autopilot(window, screenshots)
            autopilot.finished.connect(app.exit)
            autopilot.start()
        elif screenshots is not None:
            from app.autopilot import screenshot_name

            def snap(index):
                page = window.page(index)
                # the window as context: the timer is dropped if the window is gone first
                QTimer.singleShot(150, window,
                                  lambda: window.save_screenshot(screenshots / screenshot_name(page.step)))

            window.pageChanged.connect(snap)
            snap(int(window.current_step))
        if state.is_temporary() and not args.autopilot:
            window.statusBar().showMessage(
                "Demo: a temporary project on the virtual lab (deleted when RoboCal closes). "
                "Use New project to keep your work.", 15000)
        code = app.exec()
    finally:
        window.close()
        state.close()
        restore_hook()
        messages.set_non_interactive(False)
        window.deleteLater()
        app.processEvents()
    if fatal and code == 0:
        code = 1
    if autopilot is not None and autopilot.exit_code is None:
        code = code or 1   # the window was closed before the autopilot finished
    return CommandResult(exit_code=code)

