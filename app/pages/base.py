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
        def on_busy_changed(self): ...     # enable/disable controls while a task runs

and one line in app/pages/registry.py. Long work goes through the page's `self.task`
(app.pages.page_task.PageTask: one task at a time, one progress row, Cancel, errors shown in the
status line), as Orange3's ConcurrentWidgetMixin: the function is plain Python (core, or
app/jobs/<step>.py) and the page only draws what it returns.
"""
from __future__ import annotations

from typing import Callable, Optional

from PySide6.QtCore import Signal
from PySide6.QtWidgets import QWidget

from app.messages import show_error
from app.pages.forms import WrappedLabel
from app.pages.steps import Step
from app.state import WizardState
from app.pages.page_task import PageHooks, PageTask
from app.worker import TaskRunner

#: ``done(ok=True, message="")``: how a page tells the autopilot it has finished
DoneCallback = Callable[..., None]


def out_of_date(what: str, changed: list[str], again: str) -> str:
    """The words a page shows when its result was made from other input files than the project
    now has (names from core.provenance.changed_inputs)."""
    return f"Out of date: {what} was made from other inputs ({', '.join(changed)} changed since). {again}"


class WizardPage(QWidget):
    """One step of the wizard.

    Class attributes: `step` (Step), `title` and `help_name` (default from the step).
    Signal: `completeChanged()`, emitted when `is_complete()` may have changed.
    """

    step: Optional[Step] = None
    title: str = ""
    help_name: str = ""
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
        self.task = PageTask(tasks, state.labs.when_ready, PageHooks(
            set_status=self._set_status, on_failed=lambda message: self.on_failed(message),
            on_cancelled=lambda: self.on_cancelled(), on_busy_changed=lambda: self.on_busy_changed(),
            on_progress=lambda fraction, message: self.on_progress(fraction, message),
            on_cancel_requested=lambda: self.on_cancel_requested()), label=self.title)
        self._autopilot_done: DoneCallback | None = None   # set by a page's autopilot()
        self.status = WrappedLabel()            # the page's status line; a page puts it in its layout
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

    def changed_inputs(self) -> list[str]:
        """The project files changed since this step's result was made from them (names; [] when
        up to date or the step keeps no record): the step is then out of date, not done."""
        return []

    def autopilot(self, done: DoneCallback) -> None:
        """Run the step on its own (classroom demo, `robocal gui --autopilot`) and call
        ``done(True)`` when finished or ``done(False, "why")`` on failure. It may return at
        once and call `done` later (e.g. from a task's on_result)."""
        if self.is_complete():
            done(True, "")
        else:
            done(False, f"the {self.title} page has no autopilot")

    def on_failed(self, message: str) -> None:
        """A task failed: the message in the status line, the autopilot told."""
        self._set_status(f"✗ {message}", False)
        self.task.reset_progress()
        self._finish_autopilot(False, message)

    def on_cancelled(self) -> None:
        """A task was cancelled."""
        self._set_status("Cancelled.", False)
        self._finish_autopilot(False, "cancelled")

    def on_busy_changed(self) -> None:
        """A task started or ended: enable or disable the page's controls here."""

    def on_progress(self, fraction: float, message: str) -> None:
        """A task reported progress (the progress row has shown it)."""

    def on_cancel_requested(self) -> None:
        """Cancel was pressed; the task is asked to stop next."""

    # -- helpers for subclasses ----------------------------------------------------------
    def notify_complete(self) -> None:
        """Call after anything that can change `is_complete()`."""
        self.completeChanged.emit()

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
