"""The current task of one owner (a page, the virtual lab's build, the autopilot's page run), as
Orange3's TaskState with its ConcurrentMixin: starting a task cancels and disconnects the
previous one, so a replaced task's outcome never reaches its callbacks.

    task = CurrentTask(runner)                       # runner: app.worker.TaskRunner
    task.start(fn, *args, on_result=draw, on_error=say, on_cancelled=..., on_progress=..., label="…")
    task.start(other, ...)      # the first is cancelled and disconnected: nothing of it arrives
    task.cancel()               # ask the running task to stop: its on_cancelled follows
    task.forget()               # cancel and disconnect: nothing of it arrives
    task.busy                   # started and its outcome not delivered yet

Work that is not a worker task (waiting for the virtual lab, a page's autopilot run) is followed
the same way with `follow(cancel)`: the `Delivery` it returns wraps the callbacks, which run only
while that work is the current one, and its `final` callbacks at most once.
"""
from __future__ import annotations

from typing import Any, Callable

from app.worker import TaskHandle, TaskRunner


class Delivery:
    """The callbacks of one piece of work, cut off by `disconnect()`."""

    def __init__(self, owner: "CurrentTask", cancel: Callable[[], None] | None = None):
        self._owner = owner
        self.cancel_work = cancel          # asks the work to stop (a task's TaskHandle.cancel)
        self.connected = True

    def final(self, fn: Callable[..., Any]) -> Callable[..., Any]:
        """`fn` as the work's outcome: run once, only while connected; the owner is no longer
        busy when it runs (so `fn` may start the next task)."""
        def deliver(*args, **kwargs):
            if not self.connected:
                return None
            self.connected = False
            self._owner._ended(self)
            return fn(*args, **kwargs)
        return deliver

    def relay(self, fn: Callable[..., Any]) -> Callable[..., Any]:
        """`fn` as news of the running work (progress): run only while connected."""
        def deliver(*args, **kwargs):
            return fn(*args, **kwargs) if self.connected else None
        return deliver

    def disconnect(self) -> None:
        self.connected = False


def _ignore(*_args) -> None:
    return None


class CurrentTask:
    """At most one task (or followed piece of work) of one owner at a time."""

    def __init__(self, runner: TaskRunner | None = None):
        self.runner = runner
        self._current: Delivery | None = None
        self.handle: TaskHandle | None = None       # the current worker task (None: none, or not a task)

    @property
    def busy(self) -> bool:
        return self._current is not None

    def follow(self, cancel: Callable[[], None] | None = None) -> Delivery:
        """Make a new piece of work current (the previous one is cancelled and disconnected);
        `cancel()` asks it to stop. Wrap its callbacks with the returned Delivery."""
        self.forget()
        self._current = Delivery(self, cancel)
        return self._current

    def start(self, fn: Callable, *args, on_result: Callable[[Any], None] | None = None,
              on_error: Callable[[str], None] | None = None,
              on_cancelled: Callable[[], None] | None = None,
              on_progress: Callable[[float, str], None] | None = None,
              label: str = "Working", **kwargs) -> TaskHandle:
        """Run ``fn(*args, **kwargs)`` on the runner's worker thread as the current task (see
        `TaskRunner.start`). Without `on_error` a failure goes to the runner's `unhandledError`
        (a message box), as a task started on the runner directly."""
        if self.runner is None:
            raise TypeError("CurrentTask.start needs a TaskRunner")
        runner = self.runner
        work = self.follow()
        failed = on_error or (lambda message: runner.unhandledError.emit(message, label))
        handle = runner.start(fn, *args, on_result=work.final(on_result or _ignore), on_error=work.final(failed),
                              on_cancelled=work.final(on_cancelled or _ignore),
                              on_progress=work.relay(on_progress) if on_progress is not None else None,
                              label=label, **kwargs)
        work.cancel_work = handle.cancel
        if handle.running:
            self.handle = handle
        else:                                  # the runner is closing: no callback will come
            self._ended(work)
        return handle

    def cancel(self) -> None:
        """Ask the current work to stop; its outcome (usually on_cancelled) still arrives."""
        if self._current is not None and self._current.cancel_work is not None:
            self._current.cancel_work()

    def forget(self) -> None:
        """Cancel the current work and disconnect it: nothing of it arrives."""
        work, self._current, self.handle = self._current, None, None
        if work is not None:
            work.disconnect()
            if work.cancel_work is not None:
                work.cancel_work()

    def _ended(self, work: Delivery) -> None:
        if self._current is work:
            self._current = None
            self.handle = None
