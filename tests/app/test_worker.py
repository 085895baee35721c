"""app.worker: result, error and cancel paths; progress reaches the GUI thread."""
from __future__ import annotations

import threading
import time

import pytest

from app.worker import TaskRunner, error_message
from core.errors import Cancelled, RoboCalError
from core.task import Monitor


@pytest.fixture
def runner(qtbot):
    r = TaskRunner()
    yield r
    assert r.shutdown(10000)


class Outcome:
    def __init__(self):
        self.result = self.error = None
        self.cancelled = False
        self.progress = []
        self.threads = []

    def kwargs(self):
        return dict(on_result=self.set_result, on_error=self.set_error,
                    on_cancelled=self.set_cancelled, on_progress=self.add_progress)

    def set_result(self, value):
        self.threads.append(threading.current_thread())
        self.result = value

    def set_error(self, message):
        self.threads.append(threading.current_thread())
        self.error = message

    def set_cancelled(self):
        self.threads.append(threading.current_thread())
        self.cancelled = True

    def add_progress(self, fraction, message):
        self.progress.append((fraction, message))


def work(n, *, progress=None, cancelled=None):
    """A core-style function: reports progress, honours Cancel."""
    monitor = Monitor(progress, cancelled)
    seen = set()
    for i in range(n):
        monitor.step(i / n, f"item {i}")
        seen.add(threading.current_thread().name)
        time.sleep(0.01)
    monitor.step(1.0, "done")
    return {"n": n, "threads": seen}


def test_result_arrives_on_the_gui_thread(qtbot, runner):
    out = Outcome()
    with qtbot.waitSignal(runner.taskFinished, timeout=10000):
        handle = runner.start(work, 10, label="Counting", **out.kwargs())
        assert runner.busy and handle.running
    assert out.result["n"] == 10
    assert threading.main_thread().name not in out.result["threads"]   # ran on a worker
    assert out.threads == [threading.main_thread()]                     # delivered on the GUI thread
    assert handle.outcome == "result" and not handle.running and not runner.busy
    assert out.progress and out.progress[-1] == (1.0, "done")
    assert all(0.0 <= f <= 1.0 for f, _ in out.progress)
    assert out.error is None and not out.cancelled


def test_progress_signal_carries_the_label(qtbot, runner):
    seen = []
    runner.progress.connect(lambda f, m, label: seen.append((f, m, label)))
    runner.start(work, 3, label="Calibrating")
    assert runner.wait(10000)
    assert seen[0] == (0.0, "", "Calibrating")
    assert seen[-1] == (1.0, "done", "Calibrating")


def test_busy_changed_goes_true_then_false(qtbot, runner):
    states = []
    runner.busyChanged.connect(states.append)
    runner.start(work, 2)
    runner.start(work, 2)
    assert runner.wait(10000)
    assert states == [True, False]


def test_robocal_error_message_is_delivered(qtbot, runner):
    def fails():
        raise RoboCalError("cannot read the file", source="x.json", field="joints")

    out = Outcome()
    runner.start(fails, **out.kwargs())
    qtbot.waitUntil(lambda: not runner.busy, timeout=10000)
    assert out.error == "x.json: field 'joints': cannot read the file"
    assert out.result is None and out.threads == [threading.main_thread()]


def test_unexpected_error_is_type_and_message(qtbot, runner):
    def boom(x):
        return 1 / x

    out = Outcome()
    runner.start(boom, 0, **out.kwargs())
    assert runner.wait(10000)
    assert out.error == "ZeroDivisionError: division by zero"


def test_error_without_handler_is_not_dropped(qtbot, runner):
    def fails():
        raise ValueError("bad value")

    with qtbot.waitSignal(runner.unhandledError, timeout=10000) as blocker:
        runner.start(fails, label="Loading")
    assert blocker.args == ["ValueError: bad value", "Loading"]


def test_cancel_stops_the_function(qtbot, runner):
    started = threading.Event()

    def endless(*, progress=None, cancelled=None):
        monitor = Monitor(progress, cancelled)
        started.set()
        while True:
            monitor.check()
            time.sleep(0.005)

    out = Outcome()
    handle = runner.start(endless, **out.kwargs())
    assert started.wait(10)
    handle.cancel()
    qtbot.waitUntil(lambda: not runner.busy, timeout=10000)
    assert out.cancelled and handle.outcome == "cancelled"
    assert out.result is None and out.error is None


def test_cancel_all_before_start_never_runs_the_function(qtbot):
    runner = TaskRunner(max_threads=1)
    gate = threading.Event()
    ran = []

    def blocker():
        gate.wait(10)

    def second():
        ran.append(True)

    out = Outcome()
    runner.start(blocker)
    runner.start(second, **out.kwargs())
    runner.cancel_all()
    gate.set()
    assert runner.shutdown(10000)
    assert out.cancelled and not ran


def test_a_cancel_during_a_function_that_never_checks_drops_its_result(qtbot, runner):
    started, gate = threading.Event(), threading.Event()

    def build_lab():                              # takes no `cancelled`: cannot stop early
        started.set()
        gate.wait(10)
        return "lab"

    out = Outcome()
    handle = runner.start(build_lab, **out.kwargs())
    assert started.wait(10)
    handle.cancel()                               # e.g. the Stop key while it runs
    gate.set()
    qtbot.waitUntil(lambda: not runner.busy, timeout=10000)
    assert out.cancelled and out.result is None and handle.outcome == "cancelled"


def test_no_new_work_once_shutting_down(qtbot):
    runner = TaskRunner()
    assert runner.shutdown(10000)
    ran, out = [], Outcome()
    handle = runner.start(lambda: ran.append(1), **out.kwargs())
    assert handle.outcome == "cancelled" and not runner.busy
    assert runner.wait(1000) and not ran and out.result is None


def test_function_without_progress_keywords(qtbot, runner):
    out = Outcome()
    runner.start(lambda a, b=0: a + b, 2, b=3, **out.kwargs())
    assert runner.wait(10000)
    assert out.result == 5


def test_function_with_var_keywords_gets_both(qtbot, runner):
    got = {}

    def fn(**kwargs):
        got.update(kwargs)
        return True

    runner.start(fn)
    assert runner.wait(10000)
    assert set(got) == {"progress", "cancelled"} and got["cancelled"]() is False


def test_cancelled_exception_raised_directly(qtbot, runner):
    def quits():
        raise Cancelled()

    out = Outcome()
    runner.start(quits, **out.kwargs())
    assert runner.wait(10000)
    assert out.cancelled


def test_error_message_helper():
    assert error_message(RoboCalError("x", hint="Do y.")) == "x. Do y."
    assert error_message(KeyError("k")) == "KeyError: 'k'"
    assert error_message(RuntimeError()) == "RuntimeError"


def test_a_function_that_honours_cancel_keeps_its_partial_result(qtbot, runner):
    started = threading.Event()

    def measure(*, cancelled=None):                # stops early and returns what it did
        started.set()
        done = 0
        while not cancelled():
            done += 1
            time.sleep(0.002)
        return {"cancelled": True, "done": done}

    out = Outcome()
    handle = runner.start(measure, **out.kwargs())
    assert started.wait(10)
    handle.cancel()
    qtbot.waitUntil(lambda: not runner.busy, timeout=10000)
    assert out.result is not None and out.result["cancelled"] and not out.cancelled
