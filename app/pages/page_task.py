"""One long task at a time for a page: start, progress row, Cancel, and the task's outcome.

A page holds one `PageTask` as `self.task` (composed, not inherited: it keeps its own state)::

    self.task.start(fn, *args, on_done=draw, then=next_step, status="Working…")
    self.task.start_with_lab(fn, *args, on_done=draw)    # fn(..., lab=<the virtual lab>)
    self.task.busy, self.task.cancel(), self.task.forget(), self.task.progress_row()

`start` runs ``fn(*args, progress=…, cancelled=…)`` on the window's worker pool (Orange3's
ConcurrentWidgetMixin): on the GUI thread ``on_done(value)`` then ``then()``; a failure, or a
RoboCalError raised by `on_done`, goes to the page's `on_failed(message)`; Cancel to its
`on_cancelled()`. Starting while busy is refused (the status line says so). After `forget()`
(another project or robot) nothing of the task arrives. The hooks are the page's: it is told
when busy changes, when a task fails or is cancelled, of each progress step, and when Cancel is
asked for (before the task is asked to stop).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Callable

from app.task_handle import CurrentTask
from app.worker import TaskRunner
from core.errors import RoboCalError
from widgets.progress_row import ProgressRow


#: the words when work is asked for while a task runs
BUSY = "Busy: wait for the running task or cancel it."


def _nothing(*_args) -> None:
    return None


@dataclass
class PageHooks:
    """What a page is told by its task (each a plain callable on the GUI thread)."""

    set_status: Callable[[str, bool | None], None]
    on_failed: Callable[[str], None]
    on_cancelled: Callable[[], None]
    on_busy_changed: Callable[[], None] = _nothing
    on_progress: Callable[[float, str], None] = _nothing       # after the progress row moved
    on_cancel_requested: Callable[[], None] = _nothing         # Cancel pressed, before the stop


class PageTask:
    """A page's one task at a time, and its wait for the virtual lab."""

    def __init__(self, runner: TaskRunner, request_lab: Callable, hooks: PageHooks, *, label: str = "Working"):
        self._task = CurrentTask(runner)
        self._lab_wait = CurrentTask()
        self._request_lab = request_lab        # state.labs.when_ready(on_ready, on_error=) -> a cancellable wait
        self._hooks = hooks
        self._label = label
        self._row: ProgressRow | None = None

    @property
    def busy(self) -> bool:
        """A task is running, or the page waits for the virtual lab."""
        return self._task.busy or self._lab_wait.busy

    @property
    def waiting_for_lab(self) -> bool:
        return self._lab_wait.busy

    @property
    def runner(self) -> TaskRunner:
        """The window's worker pool the page's tasks run on."""
        return self._task.runner

    @property
    def handle(self):
        """The running worker task's handle (None when none runs)."""
        return self._task.handle

    def progress_row(self) -> ProgressRow:
        """The page's progress bar with its Cancel button (made on first use)."""
        if self._row is None:
            self._row = ProgressRow()
            self._row.cancelRequested.connect(self.cancel)
            self._row.set_busy(self.busy)
        return self._row

    def reset_progress(self) -> None:
        if self._row is not None:
            self._row.reset()

    def start(self, fn: Callable, *args, on_done: Callable[[Any], None], label: str = "",
              then: Callable[[], None] | None = None, status: str = "",
              on_failed: Callable[[str], None] | None = None,
              on_cancelled: Callable[[], None] | None = None, **kwargs) -> bool:
        """Run `fn` on a worker unless a task is running (then say so and return False)."""
        if self.busy:
            self._hooks.set_status(BUSY, False)
            return False
        failed = on_failed or self._hooks.on_failed
        cancelled_ = on_cancelled or self._hooks.on_cancelled

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
                         on_progress=self._progress, label=label or self._label, **kwargs)
        self._busy_changed()
        if status:
            self._hooks.set_status(status, None)
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
            self._hooks.set_status(BUSY, False)
            return False
        answers = []
        self.follow_lab(lambda lab: answers.append(go(lab) is not False), on_failed or self._hooks.on_failed)
        if self._lab_wait.busy:                           # still waiting: the lab is being built
            self._hooks.set_status(status or "Building the virtual lab…", None)
        return answers[0] if answers else True

    def follow_lab(self, go: Callable[[Any], Any], on_failed: Callable[[str], None]) -> None:
        """Wait (busy) for the state's virtual lab, then `go(lab)`; a failed build: `on_failed`.
        While the lab is being built the progress row says so."""
        wait = self._lab_wait.follow()

        def ready(lab) -> None:
            self._busy_changed()
            go(lab)

        def failed(message: str) -> None:
            self._busy_changed()
            on_failed(message)

        self._busy_changed()
        wait.cancel_work = self._request_lab(wait.final(ready), on_error=wait.final(failed)).cancel
        if self._lab_wait.busy:                           # still waiting: the lab is being built
            self.progress_row().set_progress(0.0, "building the virtual lab")

    def cancel(self) -> None:
        """Ask the running task to stop, or stop waiting for the lab (`on_cancelled` follows)."""
        self._hooks.on_cancel_requested()
        if self._lab_wait.busy:
            self._lab_wait.forget()
            self._busy_changed()
            self.reset_progress()
            self._hooks.on_cancelled()
        else:
            self._task.cancel()

    def forget(self) -> None:
        """Cancel the running task (or the wait for the lab): nothing of it arrives (the project
        or robot changed)."""
        was_busy = self.busy
        self._lab_wait.forget()
        self._task.forget()
        if was_busy:
            self._busy_changed()

    def _busy_changed(self) -> None:
        if self._row is not None:
            self._row.set_busy(self.busy)
        self._hooks.on_busy_changed()

    def _progress(self, fraction: float, message: str) -> None:
        if self._row is not None:
            self._row.set_progress(fraction, message)
        self._hooks.on_progress(fraction, message)
