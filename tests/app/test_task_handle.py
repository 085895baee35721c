"""CurrentTask: starting a task cancels and disconnects the previous one; cancel, forget, errors."""
from __future__ import annotations

import threading

import pytest

from app.task_handle import CurrentTask
from app.worker import TaskRunner
from core.errors import Cancelled, RoboCalError
from core.task import Monitor


@pytest.fixture
def runner(qtbot):
    r = TaskRunner()
    yield r
    r.shutdown()


def blocked(gate: threading.Event, value):
    """A task that waits for `gate` and ignores Cancel (as a long OpenCV call); `fn.started` is
    set once it runs on the worker."""
    def fn():
        fn.started.set()
        gate.wait(5)
        return value
    fn.started = threading.Event()
    return fn


def test_a_replaced_task_delivers_nothing_and_the_new_one_its_result(runner, qtbot):
    task, got = CurrentTask(runner), []
    gate = threading.Event()
    old = blocked(gate, "old")
    first = task.start(old, on_result=got.append, on_error=got.append,
                       on_cancelled=lambda: got.append("cancelled"), on_progress=lambda f, m: got.append(m))
    assert old.started.wait(5)
    second = task.start(lambda: "new", on_result=got.append)
    assert first.event.is_set() and task.busy and task.handle is second
    with qtbot.waitSignal(runner.taskFinished, check_params_cb=lambda h: h is second):
        pass
    assert got == ["new"] and not task.busy
    with qtbot.waitSignal(runner.taskFinished, check_params_cb=lambda h: h is first):
        gate.set()
    assert first.outcome == "cancelled" and got == ["new"]       # its outcome came and was dropped


def test_a_replaced_task_that_honours_cancel_stops(runner, qtbot):
    task, got = CurrentTask(runner), []

    def endless(*, progress=None, cancelled=None):
        m = Monitor(progress, cancelled)
        while True:
            m.step(0.0, "working")
            threading.Event().wait(0.005)
    first = task.start(endless, on_cancelled=lambda: got.append("first cancelled"))
    with qtbot.waitSignals([(runner.taskFinished, "first"), (runner.taskFinished, "second")], order="none",
                           check_params_cbs=[lambda h: h is first, lambda h: h.outcome == "result"]):
        task.start(lambda: 7, on_result=got.append)
    assert first.outcome == "cancelled" and got == [7]


def test_cancel_delivers_on_cancelled_once(runner, qtbot):
    task, got = CurrentTask(runner), []

    def until_cancelled(*, cancelled=None):
        while not cancelled():
            threading.Event().wait(0.005)
        raise Cancelled()
    handle = task.start(until_cancelled, on_result=got.append, on_cancelled=lambda: got.append("cancelled"))
    with qtbot.waitSignal(runner.taskFinished):
        task.cancel()
        assert task.busy                                # until its outcome arrives
    assert got == ["cancelled"] and handle.outcome == "cancelled" and not task.busy


def test_forget_cancels_and_nothing_arrives(runner, qtbot):
    task, got = CurrentTask(runner), []
    gate = threading.Event()
    fn = blocked(gate, 1)
    handle = task.start(fn, on_result=got.append, on_cancelled=lambda: got.append("cancelled"))
    assert fn.started.wait(5)
    task.forget()
    assert not task.busy and task.handle is None and handle.event.is_set()
    with qtbot.waitSignal(runner.taskFinished):
        gate.set()
    assert got == []


def test_errors_reach_on_error_or_the_runner_and_never_from_a_replaced_task(runner, qtbot):
    task, got = CurrentTask(runner), []

    def broken():
        raise RoboCalError("no board in left01.png")
    with qtbot.waitSignal(runner.taskFinished):
        task.start(broken, on_error=got.append)
    assert got == ["no board in left01.png"] and not task.busy

    with qtbot.waitSignal(runner.unhandledError) as shown:          # no on_error: a message box
        task.start(broken, label="Detecting")
    assert shown.args == ["no board in left01.png", "Detecting"]

    gate = threading.Event()

    started = threading.Event()

    def broken_later():
        started.set()
        gate.wait(5)
        raise RoboCalError("too late")
    unhandled = []
    runner.unhandledError.connect(lambda message, label: unhandled.append(message))
    replaced = task.start(broken_later)
    assert started.wait(5)
    task.start(lambda: 1)
    with qtbot.waitSignal(runner.taskFinished, check_params_cb=lambda h: h is replaced):
        gate.set()
    assert replaced.outcome == "error" and unhandled == []


def test_followed_work_is_delivered_once_and_only_while_current(qtbot):
    work, stopped, got = CurrentTask(), [], []
    first = work.follow(cancel=lambda: stopped.append("first"))
    done_first = first.final(lambda ok, message="": got.append(("first", ok)))
    second = work.follow()
    assert stopped == ["first"] and work.busy
    done_first(True)                                # late: cut off
    done_second = second.final(lambda ok, message="": got.append(("second", ok, message)))
    done_second(False, "cancelled")
    done_second(True)                               # repeated: once only
    assert got == [("second", False, "cancelled")] and not work.busy
