"""The classroom demo walked once per test session, in-process (~1 min: render, calibrate,
train, measure, identify, check, compensate): a fresh MainWindow(WizardState()) on the project
folder that `robocal gui --demo --autopilot --screenshots DIR PROJECT` creates (the command's own
argument parser and app.commands.gui.prepare_state: a new project, the educational 6R arm), whose
Autopilot runs every page with the screenshot folder (the Setup page's autopilot on an empty
state: tests/app/pages/test_setup_page.py). The tests that
read it (tests/app/test_autopilot.py, tests/app/test_small_screens.py) run on one pytest-xdist
worker (tests/scheduling.py), so it is walked once. tests/app/conftest.py exposes it as the
session fixture `demo_walk`; the window is hidden between tests and closed at the end."""
from __future__ import annotations

import io
import tempfile
from dataclasses import dataclass, field
from pathlib import Path

import pytest
from PySide6.QtCore import QEventLoop, QTimer
from PySide6.QtWidgets import QApplication

WALK_TIMEOUT_MS = 1_200_000       # ~1 min alone; a machine busy with other work is many times slower


@dataclass
class DemoWalk:
    """The window after the walk, and what the walk ended with (the window's pages move on as
    tests use it; these do not)."""

    window: object
    exit_code: int | None
    output: str                    # the autopilot's lines
    project: Path                  # the project folder the command line named
    screenshots: Path
    saved: list[Path] = field(default_factory=list)
    finished_step: object = None   # the window's current step when the walk finished


def walk_the_demo(folder: Path):
    """Yield the DemoWalk of one autopilot run from a fresh window on the project folder
    `folder`/project (temporary files and screenshots under `folder` too); close the window afterwards."""
    from app import messages
    from app.autopilot import Autopilot
    from app.cli import build_parser
    from app.commands.gui import prepare_state
    from app.main_window import MainWindow
    from app.state import WizardState
    from tests.app.windows import close_window

    with pytest.MonkeyPatch.context() as mp:
        temp = folder / "tempfile"
        temp.mkdir(parents=True)
        mp.setattr(tempfile, "tempdir", str(temp))
        messages.set_non_interactive(True)
        try:
            args = build_parser().parse_args(["gui", "--demo", "--autopilot", "--screenshots",
                                              str(folder / "shots"), str(folder / "project")])
            state = WizardState()
            prepare_state(state, args)
            win = MainWindow(state)
            win.show()
            out = io.StringIO()
            pilot = Autopilot(win, args.screenshots, out=out)
            loop = QEventLoop()
            pilot.finished.connect(loop.quit)
            QTimer.singleShot(WALK_TIMEOUT_MS, loop.quit)
            pilot.start()
            loop.exec()
            walk = DemoWalk(win, pilot.exit_code, out.getvalue(), Path(args.project), Path(args.screenshots),
                            list(pilot.saved), win.current_step)
            while win.tasks.busy:                   # a page's refresh on entry
                QApplication.processEvents(QEventLoop.ProcessEventsFlag.WaitForMoreEvents, 50)
        finally:
            messages.set_non_interactive(False)
        win.hide()
        try:
            yield walk
        finally:
            win.show()
            close_window(win)
            state.close()
            win.deleteLater()
            QApplication.processEvents()
