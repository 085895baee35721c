"""Run long core functions on a worker thread (the Orange3 TaskState pattern with Qt).

A core function is plain Python: ``fn(*args, progress=None, cancelled=None, **kwargs)``
(see core/task.py). `TaskRunner.start` runs it on its own QThreadPool and hands it

- ``progress(fraction, message)``: delivered to the GUI thread as the runner's `progress`
  signal (the main window shows it in the status bar), throttled to ~20 updates per second;
- ``cancelled()``: reads a `threading.Event` that `TaskHandle.cancel()` / `cancel_all()` set
  (the status bar's Cancel button); the function raises `core.errors.Cancelled`.

The outcome comes back on the GUI thread, exactly once per task:
``on_result(value)``, ``on_error(message)`` or ``on_cancelled()``. The error message is the
RoboCalError's message, or ``"Type: message"`` for an unexpected exception (whose traceback
is also logged). An error with no ``on_error`` is emitted as `unhandledError` (the main
window shows it in a message box): never silently dropped.

Functions that take no ``progress``/``cancelled`` keywords are called without them.

An owner with one task at a time (a page, the virtual lab's build) holds it in an
`app.task_handle.CurrentTask`, which cancels and disconnects the task it replaces.

Tests wait with ``qtbot.waitUntil(lambda: not runner.busy)`` or ``runner.wait()``, and call
``runner.shutdown()`` at teardown so no thread outlives the test.
"""
from __future__ import annotations

import inspect
import logging
import threading
import time
import weakref
from typing import Any, Callable, Optional

from PySide6.QtCore import QObject, QRunnable, QThreadPool, Signal, Slot
from PySide6.QtWidgets import QApplication

from core.errors import Cancelled, RoboCalError

log = logging.getLogger(__name__)

_RUNNERS: "weakref.WeakSet[TaskRunner]" = weakref.WeakSet()


def live_runners() -> list["TaskRunner"]:
    """Every TaskRunner not yet garbage-collected (the test suite checks none is busy)."""
    return list(_RUNNERS)


def error_message(exc: BaseException) -> str:
    """What the user reads about an exception: the RoboCalError message as is, otherwise
    ``Type: message``."""
    if isinstance(exc, RoboCalError):
        return exc.message
    text = str(exc)
    return f"{type(exc).__name__}: {text}" if text else type(exc).__name__


def _accepts(fn: Callable, name: str) -> bool:
    try:
        params = inspect.signature(fn).parameters
    except (TypeError, ValueError):
        return False
    return name in params or any(p.kind is p.VAR_KEYWORD for p in params.values())


class _Signals(QObject):
    """Carries a task's news from the worker thread to the GUI thread (queued)."""

    progress = Signal(int, float, str)
    result = Signal(int, object)
    error = Signal(int, str)
    cancelled = Signal(int)


class TaskHandle:
    """What `TaskRunner.start` returns: cancel it, ask whether it is still running."""

    def __init__(self, task_id: int, label: str):
        self.id = task_id
        self.label = label
        self.event = threading.Event()
        self.running = True
        self.outcome: str | None = None   # "result" | "error" | "cancelled"
        self.on_result: Optional[Callable[[Any], None]] = None
        self.on_error: Optional[Callable[[str], None]] = None
        self.on_cancelled: Optional[Callable[[], None]] = None
        self.on_progress: Optional[Callable[[float, str], None]] = None

    def cancel(self) -> None:
        """Ask the function to stop (it sees `cancelled()` become True)."""
        self.event.set()


    def __repr__(self) -> str:
        return f"<TaskHandle {self.id} {self.label!r} running={self.running} outcome={self.outcome}>"


class _Job(QRunnable):
    def __init__(self, handle: TaskHandle, signals: _Signals, fn, args, kwargs, throttle: float):
        super().__init__()
        self.setAutoDelete(True)
        self.handle, self.signals, self.fn, self.args, self.kwargs = handle, signals, fn, args, kwargs
        self.throttle = throttle
        self._last = 0.0

    def _progress(self, fraction: float, message: str = "") -> None:
        now = time.monotonic()
        if fraction < 1.0 and now - self._last < self.throttle:
            return
        self._last = now
        self.signals.progress.emit(self.handle.id, float(fraction), str(message))

    def run(self) -> None:  # worker thread
        hid = self.handle.id
        kwargs = dict(self.kwargs)
        if _accepts(self.fn, "progress"):
            kwargs.setdefault("progress", self._progress)
        honours_cancel = _accepts(self.fn, "cancelled")
        if honours_cancel:
            kwargs.setdefault("cancelled", self.handle.event.is_set)
        try:
            if self.handle.event.is_set():
                raise Cancelled()
            value = self.fn(*self.args, **kwargs)
        except Cancelled:
            self.signals.cancelled.emit(hid)
        except RoboCalError as exc:
            self.signals.error.emit(hid, error_message(exc))
        except BaseException as exc:  # noqa: BLE001 - reported to the user, never dropped
            log.error("task %r failed", self.handle.label, exc_info=exc)
            self.signals.error.emit(hid, error_message(exc))
        else:
            if self.handle.event.is_set() and not honours_cancel:
                self.signals.cancelled.emit(hid)   # Cancel (or Stop) came while fn, which cannot
            else:                                  # see it, ran: its result is not used
                self.signals.result.emit(hid, value)


class TaskRunner(QObject):
    """Starts core functions on worker threads and delivers their outcome on the GUI thread.

    Signals (GUI thread): `progress(fraction, message, label)`, `busyChanged(bool)`,
    `taskFinished(TaskHandle)`, `unhandledError(message, label)`.
    """

    progress = Signal(float, str, str)
    busyChanged = Signal(bool)
    taskFinished = Signal(object)
    unhandledError = Signal(str, str)

    def __init__(self, parent: QObject | None = None, *, max_threads: int = 2,
                 progress_interval: float = 0.05):
        super().__init__(parent)
        self._pool = QThreadPool(self)
        self._pool.setMaxThreadCount(max_threads)
        self._signals = _Signals(self)
        self._signals.progress.connect(self._on_progress)
        self._signals.result.connect(self._on_result)
        self._signals.error.connect(self._on_error)
        self._signals.cancelled.connect(self._on_cancelled)
        self._tasks: dict[int, TaskHandle] = {}
        self._next_id = 1
        self._interval = progress_interval
        self._closing = False
        _RUNNERS.add(self)

    # -- starting and stopping -----------------------------------------------------------
    def start(self, fn: Callable, *args, on_result: Callable[[Any], None] | None = None,
              on_error: Callable[[str], None] | None = None,
              on_cancelled: Callable[[], None] | None = None,
              on_progress: Callable[[float, str], None] | None = None,
              label: str = "Working", **kwargs) -> TaskHandle:
        """Run ``fn(*args, **kwargs)`` (plus ``progress=``/``cancelled=`` when it takes them)
        on a worker thread. Callbacks run on the GUI thread."""
        handle = TaskHandle(self._next_id, label)
        self._next_id += 1
        if self._closing:                   # the window is closing: no new work, no callbacks
            handle.running, handle.outcome = False, "cancelled"
            handle.event.set()
            return handle
        handle.on_result, handle.on_error = on_result, on_error
        handle.on_cancelled, handle.on_progress = on_cancelled, on_progress
        was_busy = self.busy
        self._tasks[handle.id] = handle
        if not was_busy:
            self.busyChanged.emit(True)
        self.progress.emit(0.0, "", label)
        self._pool.start(_Job(handle, self._signals, fn, args, kwargs, self._interval))
        return handle

    def cancel_all(self) -> None:
        for handle in list(self._tasks.values()):
            handle.cancel()

    @property
    def busy(self) -> bool:
        return bool(self._tasks)

    def running_tasks(self) -> list[TaskHandle]:
        return list(self._tasks.values())

    def wait(self, timeout_ms: int = 30000) -> bool:
        """Block until every task finished and its outcome was delivered (tests, shutdown).
        Returns False on timeout."""
        deadline = time.monotonic() + timeout_ms / 1000.0
        while True:
            remaining = int(max(0.0, deadline - time.monotonic()) * 1000)
            self._pool.waitForDone(min(remaining, 50))
            app = QApplication.instance()
            if app is not None:
                app.processEvents()
            if not self._tasks:
                return True
            if time.monotonic() >= deadline:
                return False

    def shutdown(self, timeout_ms: int = 30000) -> bool:
        """Cancel everything, refuse new work, and wait for the threads (closing the window,
        test teardown)."""
        self._closing = True
        self.cancel_all()
        done = self.wait(timeout_ms)
        self._pool.waitForDone(timeout_ms)
        self._pool.clear()
        return done

    # -- delivery (GUI thread) -----------------------------------------------------------
    def _finish(self, hid: int, outcome: str) -> TaskHandle | None:
        handle = self._tasks.pop(hid, None)
        if handle is None:
            return None
        handle.running = False
        handle.outcome = outcome
        return handle

    def _after(self, handle: TaskHandle) -> None:
        self.taskFinished.emit(handle)
        if not self._tasks:
            self.busyChanged.emit(False)

    @Slot(int, float, str)
    def _on_progress(self, hid: int, fraction: float, message: str) -> None:
        handle = self._tasks.get(hid)
        if handle is None:
            return
        if handle.on_progress is not None:
            handle.on_progress(fraction, message)
        self.progress.emit(fraction, message, handle.label)

    @Slot(int, object)
    def _on_result(self, hid: int, value: object) -> None:
        handle = self._finish(hid, "result")
        if handle is None:
            return
        try:
            if handle.on_result is not None:
                handle.on_result(value)
        finally:
            self._after(handle)

    @Slot(int, str)
    def _on_error(self, hid: int, message: str) -> None:
        handle = self._finish(hid, "error")
        if handle is None:
            return
        try:
            if handle.on_error is not None:
                handle.on_error(message)
            else:
                self.unhandledError.emit(message, handle.label)
        finally:
            self._after(handle)

    @Slot(int)
    def _on_cancelled(self, hid: int) -> None:
        handle = self._finish(hid, "cancelled")
        if handle is None:
            return
        try:
            if handle.on_cancelled is not None:
                handle.on_cancelled()
        finally:
            self._after(handle)
