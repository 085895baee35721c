"""`robocal gui --autopilot`: walk every page in order, let each do its work on its own,
move Next when it is done, and finish with an exit code (0: every page finished, 1: a page
failed). With a screenshot folder, save `NN-<step>.png` of the whole window for each page."""
from __future__ import annotations

import sys
from pathlib import Path

from PySide6.QtCore import QObject, QTimer, Signal
from PySide6.QtWidgets import QApplication

from app.task_handle import CurrentTask
from app.worker import error_message


def screenshot_name(step) -> str:
    return f"{step.number:02d}-{step.slug}.png"


class Autopilot(QObject):
    """`start()` it once the window is shown; `finished(exit_code)` is emitted at the end."""

    finished = Signal(int)

    def __init__(self, window, screenshots: str | Path | None = None, *,
                 page_timeout_s: float = 900.0, out=None):
        super().__init__(window)
        self.window = window
        self.count = len(window.pages)
        self.screenshots = Path(screenshots) if screenshots else None
        self.page_timeout_ms = int(page_timeout_s * 1000)
        self.out = out or sys.stdout
        self.index = -1
        self.exit_code: int | None = None
        self.saved: list[Path] = []
        self._page_run = CurrentTask()     # the current page's autopilot run: a late `done` is cut off
        self._timer = QTimer(self)
        self._timer.setSingleShot(True)
        self._timer.timeout.connect(self._timed_out)

    def start(self) -> None:
        QTimer.singleShot(0, lambda: self._run(0))

    def _say(self, text: str) -> None:
        self.out.write(text + "\n")
        self.out.flush()

    def _run(self, index: int) -> None:
        if self.exit_code is not None:
            return
        self.index = index
        run = self._page_run.follow()
        done = run.final(lambda ok=True, message="": self._done(ok, message))   # once, while current
        page = self.window.go_to(index)
        QApplication.processEvents()
        self._timer.start(self.page_timeout_ms)
        try:
            page.autopilot(done)
        except Exception as exc:  # noqa: BLE001 - a failing page fails the run, with its reason
            done(False, error_message(exc))

    def _done(self, ok: bool, message: str) -> None:
        if self.exit_code is not None:
            return
        self._timer.stop()
        # let the page draw its result, then take the picture and go on
        QTimer.singleShot(0, lambda: self._after(bool(ok), message or ""))

    def _after(self, ok: bool, message: str) -> None:
        page = self.window.current_page()
        n = len(self.window.pages)
        status = "done" if ok else "FAILED"
        self._say(f"[{page.step.number}/{n}] {page.title}: {status}" + (f" ({message})" if message else ""))
        if self.screenshots is not None:
            try:
                self.saved.append(self.window.save_screenshot(self.screenshots / screenshot_name(page.step)))
            except Exception as exc:  # noqa: BLE001
                self._finish(1, f"screenshot failed: {error_message(exc)}")
                return
        if not ok:
            self._finish(1, f"the {page.title} step failed: {message or 'no reason given'}")
        elif self.index + 1 >= self.count:
            self._finish(0, "every page finished")
        else:
            self._run(self.index + 1)

    def _timed_out(self) -> None:
        page = self.window.current_page()
        self._page_run.forget()
        self.window.tasks.cancel_all()
        self._finish(1, f"the {page.title} step did not finish within {self.page_timeout_ms // 1000} s")

    def _finish(self, code: int, message: str) -> None:
        if self.exit_code is not None:
            return
        self.exit_code = code
        self._say(f"autopilot: {message}" + (f"; screenshots in {self.screenshots}" if self.saved else ""))
        self.finished.emit(code)
