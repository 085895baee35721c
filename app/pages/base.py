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

and one line in app/pages/registry.py. Long work goes through `TaskMixin.start` (one task at
a time per page, one progress row, Cancel, errors shown in the status line), as Orange3's
ConcurrentWidgetMixin: the function is plain Python (core, or app/jobs/<step>.py) and the
page only draws what it returns.
"""
from __future__ import annotations

from typing import Any, Callable, Optional

from PySide6.QtCore import Signal
from PySide6.QtWidgets import QWidget

from app.messages import show_error
from app.pages.forms import WrappedLabel
from app.pages.steps import Step
from app.state import WizardState
from app.task_handle import CurrentTask
from app.worker import TaskRunner
from core.errors import RoboCalError
from widgets.progress_row import ProgressRow

#: ``done(ok=True, message="")``: how a page tells the autopilot it has finished
DoneCallback = Callable[..., None]


def out_of_date(what: str, changed: list[str], again: str) -> str:
    """The words a page shows when its result was made from other input files than the project
    now has (names from core.provenance.changed_inputs)."""
    return f"Out of date: {what} was made from other inputs ({', '.join(changed)} changed since). {again}"


class TaskMixin:
    """One long task at a time for a page: start, progress, Cancel, and its outcome.

    ``self.start(fn, *args, on_done=draw, then=next_step, status="Working…")`` runs
    ``fn(*args, progress=…, cancelled=…)`` on the window's worker pool. On the GUI thread:
    ``on_done(value)`` then ``then()``; a failure or a RoboCalError raised by `on_done` goes to
    `on_failed(message)` (status line, autopilot told); Cancel to `on_cancelled()`. After
    `forget_task()` (another project or robot) nothing of the task arrives. `progress_row()` is the
    page's progress bar and Cancel button; `on_busy_changed()` is the hook to enable controls.
    `start_with_lab(...)` first asks the state for the virtual lab (built once, on a worker) and
    counts as busy while it waits. Needs `state`, `_task` and `_lab_wait` (app.task_handle.
    CurrentTask: the page's task and its wait for the lab), `_set_status` and `_finish_autopilot`
    (WizardPage has them).
    """

    _task: CurrentTask
    _lab_wait: CurrentTask
    _progress_row: ProgressRow | None = None

    @property
    def busy(self) -> bool:
        """A task of this page is running, or waits for the virtual lab."""
        return self._task.busy or self._lab_wait.busy

    @property
    def waiting_for_lab(self) -> bool:
        return self._lab_wait.busy

    def progress_row(self) -> ProgressRow:
        """The page's progress bar with its Cancel button (made on first use)."""
        if self._progress_row is None:
            self._progress_row = ProgressRow()
            self._progress_row.cancelRequested.connect(self.cancel)
            self._progress_row.set_busy(self.busy)
        return self._progress_row

    def start(self, fn: Callable, *args, on_done: Callable[[Any], None], label: str = "",
              then: Callable[[], None] | None = None, status: str = "",
              on_failed: Callable[[str], None] | None = None,
              on_cancelled: Callable[[], None] | None = None, **kwargs) -> bool:
        """Run `fn` on a worker unless a task is running (then say so and return False)."""
        if self.busy:
            self._set_status("Busy: wait for the running task or cancel it.", False)
            return False
        failed = on_failed or self.on_failed
        cancelled_ = on_cancelled or self.on_cancelled

        def result(value):
            self._busy_changed()
            try:
                on_done(value)
            except RoboCalError as exc:
                failed(exc.message)
                return
            if then is not None:
                then()

        def error(message: str):
            self._busy_changed()
            failed(message)

        def cancelled():
            self._busy_changed()
            cancelled_()

        self._task.start(fn, *args, on_result=result, on_error=error, on_cancelled=cancelled,
                         on_progress=self._task_progress, label=label or self.title, **kwargs)
        self._busy_changed()
        if status:
            self._set_status(status, None)
        return True

    def start_with_lab(self, fn: Callable, *args, on_done: Callable[[Any], None], lab_keyword: str = "lab",
                       status: str = "", **kwargs) -> bool:
        """`start(fn, *args, lab=<the virtual lab>, ...)` once the state has built the lab (see
        `with_lab`)."""
        def go(lab) -> bool:
            return self.start(fn, *args, on_done=on_done, status=status, **{lab_keyword: lab}, **kwargs)

        return self.with_lab(go, status=status, on_failed=kwargs.get("on_failed"))

    def with_lab(self, go: Callable[[Any], Any], *, status: str = "",
                 on_failed: Callable[[str], None] | None = None) -> bool:
        """`go(lab)` once the state has built the virtual lab (at once when it exists). Busy
        meanwhile; Cancel stops the wait (the build goes on for the other pages); a failed
        build goes to `on_failed`. Returns `go`'s answer (None counts as True) when the lab
        exists, True while it is being built, False (nothing done) while a task is running."""
        if self.busy:
            self._set_status("Busy: wait for the running task or cancel it.", False)
            return False
        answers = []
        self._follow_lab(lambda lab: answers.append(go(lab) is not False), on_failed or self.on_failed)
        if self._lab_wait.busy:                           # still waiting: the lab is being built
            self.progress_row().set_progress(0.0, "building the virtual lab")
            self._set_status(status or "Building the virtual lab…", None)
        return answers[0] if answers else True

    def _follow_lab(self, go: Callable[[Any], Any], on_failed: Callable[[str], None]) -> None:
        """Wait (busy) for the state's virtual lab, then `go(lab)`; a failed build: `on_failed`."""
        wait = self._lab_wait.follow()

        def ready(lab) -> None:
            self._busy_changed()
            go(lab)

        def failed(message: str) -> None:
            self._busy_changed()
            on_failed(message)

        self._busy_changed()
        wait.cancel_work = self.state.request_lab(wait.final(ready), on_error=wait.final(failed)).cancel

    def cancel(self) -> None:
        """Ask the running task to stop, or stop waiting for the lab (`on_cancelled` follows)."""
        if self._lab_wait.busy:
            self._lab_wait.forget()
            self._busy_changed()
            if self._progress_row is not None:
                self._progress_row.reset()
            self.on_cancelled()
        else:
            self._task.cancel()

    def forget_task(self) -> None:
        """Cancel the running task (or the wait for the lab): nothing of it arrives (the project
        or robot changed)."""
        was_busy = self.busy
        self._lab_wait.forget()
        self._task.forget()
        if was_busy:
            self._busy_changed()

    def on_failed(self, message: str) -> None:
        """Default outcome of a failed task: the message in the status line, the autopilot told."""
        self._set_status(f"✗ {message}", False)
        if self._progress_row is not None:
            self._progress_row.reset()
        self._finish_autopilot(False, message)

    def on_cancelled(self) -> None:
        """Default outcome of a cancelled task."""
        self._set_status("Cancelled.", False)
        self._finish_autopilot(False, "cancelled")

    def on_busy_changed(self) -> None:
        """A task started or ended: enable or disable the page's controls here."""

    def _busy_changed(self) -> None:
        if self._progress_row is not None:
            self._progress_row.set_busy(self.busy)
        self.on_busy_changed()

    def _task_progress(self, fraction: float, message: str) -> None:
        if self._progress_row is not None:
            self._progress_row.set_progress(fraction, message)


class WizardPage(TaskMixin, QWidget):
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
        self.tasks = tasks
        self._task = CurrentTask(tasks)           # the page's one task at a time (TaskMixin)
        self._lab_wait = CurrentTask()            # its wait for the virtual lab
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
