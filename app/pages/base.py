"""The base class of every wizard page.

A page is a QWidget built from the shared `WizardState` and the window's `TaskRunner`:

    class StereoPage(WizardPage):
        step = Step.STEREO

        def __init__(self, state, tasks, **kwargs):
            super().__init__(state, tasks, **kwargs)
            ...build widgets...

        def on_enter(self): ...            # the page became current
        def is_complete(self): ...         # from real state; call self.notify_complete()
        def autopilot(self, done): ...     # do the work alone, then done(True) / done(False, why)

and one line in app/pages/registry.py: ``Step.STEREO: "app.pages.stereo_page:StereoPage"``.
"""
from __future__ import annotations

from typing import Any, Callable, Optional

from PySide6.QtCore import Signal
from PySide6.QtWidgets import QLabel, QWidget

from app.messages import show_error
from app.pages.steps import Step
from app.state import WizardState
from app.worker import TaskHandle, TaskRunner

#: ``done(ok=True, message="")``: how a page tells the autopilot it has finished
DoneCallback = Callable[..., None]


class WizardPage(QWidget):
    """One step of the wizard.

    Class attributes: `step` (Step), `title` and `help_name` (default from the step),
    `built` (False only for the placeholder of a step that is not built yet).
    Signal: `completeChanged()`, emitted when `is_complete()` may have changed.
    """

    step: Optional[Step] = None
    title: str = ""
    help_name: str = ""
    built: bool = True
    load_error: Optional[str] = None   # set on the stand-in of a page that failed to load

    completeChanged = Signal()

    def __init__(self, state: WizardState, tasks: TaskRunner, *, step: Step | None = None,
                 parent: QWidget | None = None):
        super().__init__(parent)
        if self.step is None:
            if step is None:
                raise TypeError(f"{type(self).__name__} needs a step (class attribute or step=)")
            self.step = Step(step)
        elif step is not None and Step(step) != self.step:
            raise TypeError(f"{type(self).__name__} is the page of {self.step.name}, "
                            f"registered for {Step(step).name}")
        self.title = self.title or self.step.info.title
        self.help_name = self.help_name or self.step.slug
        self.state = state
        self.tasks = tasks
        self._autopilot_done: DoneCallback | None = None   # set by a page's autopilot()
        self.status = QLabel()                  # the page's status line; a page puts it in its layout
        self.status.setObjectName("pageStatus")
        self.status.setWordWrap(True)
        self.setObjectName(f"page_{self.step.slug}")

    # -- to override ---------------------------------------------------------------------
    def on_enter(self) -> None:
        """The page became the current one (refresh from `self.state` here)."""

    def on_leave(self) -> None:
        """Another page is about to become current."""

    def is_complete(self) -> bool:
        """True when the step's output exists, so Next may go on (PySide's QWizardPage idea)."""
        return False

    def autopilot(self, done: DoneCallback) -> None:
        """Run the step on its own (classroom demo, `robocal gui --autopilot`) and call
        ``done(True)`` when finished or ``done(False, "why")`` on failure. It may return at
        once and call `done` later (e.g. from a task's on_result)."""
        if self.is_complete():
            done(True, "")
        else:
            done(False, f"the {self.title} page has no autopilot")

    # -- helpers for subclasses ----------------------------------------------------------
    def notify_complete(self) -> None:
        """Call after anything that can change `is_complete()`."""
        self.completeChanged.emit()

    def run_task(self, fn: Callable, *args, on_result: Callable[[Any], None] | None = None,
                 on_error: Callable[[str], None] | None = None,
                 on_cancelled: Callable[[], None] | None = None,
                 on_progress: Callable[[float, str], None] | None = None,
                 label: str = "", **kwargs) -> TaskHandle:
        """Run a core function on a worker thread: progress and Cancel in the status bar,
        callbacks on the GUI thread. Without `on_error`, errors are shown in a message box."""
        return self.tasks.start(fn, *args, on_result=on_result, on_error=on_error,
                                on_cancelled=on_cancelled, on_progress=on_progress,
                                label=label or self.title, **kwargs)

    def _finish_autopilot(self, ok: bool, message: str = "") -> None:
        """Report the end of an autopilot run once (a page stores `done` in `_autopilot_done`)."""
        done, self._autopilot_done = self._autopilot_done, None
        if done is not None:
            done(ok, message)

    def _set_status(self, text: str, ok: bool | None = None) -> None:
        """Show `text` in the page's status line `self.status`: green when ok, amber otherwise
        (the main window's style sheet)."""
        self.status.setText(text)
        self.status.setProperty("ok", "true" if ok else "false")
        self.status.style().unpolish(self.status)
        self.status.style().polish(self.status)

    def show_error(self, message: str) -> None:
        show_error(self, message, f"RoboCal: {self.title}")
