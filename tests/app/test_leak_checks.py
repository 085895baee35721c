"""The suite's own guards (tests/conftest.py) see what they must: open windows, running
QThreads, busy task runners. Each test cleans up before it ends, so the guard passes."""
from __future__ import annotations

import threading

from PySide6.QtCore import QThread
from PySide6.QtWidgets import QWidget

from app.worker import TaskRunner
from tests.conftest import QThreadTracker, busy_runners, visible_top_level_windows


def test_open_window_is_seen(qtbot):
    w = QWidget()
    w.setObjectName("leaky")
    w.show()
    try:
        assert w in visible_top_level_windows()
    finally:
        w.close()
        w.deleteLater()
    assert w not in visible_top_level_windows()


def test_running_qthread_is_seen(qtbot, monkeypatch):
    tracker = QThreadTracker(monkeypatch)
    gate = threading.Event()

    class Worker(QThread):
        def run(self):
            gate.wait(10)

    t = Worker()
    t.start()
    try:
        assert tracker.running() == [t]
    finally:
        gate.set()
        t.wait(10000)
    assert tracker.running() == []


def test_busy_runner_is_seen(qtbot):
    runner = TaskRunner()
    gate = threading.Event()
    runner.start(gate.wait, 10)
    try:
        assert runner in busy_runners()
    finally:
        gate.set()
        runner.shutdown(10000)
    assert runner not in busy_runners()
