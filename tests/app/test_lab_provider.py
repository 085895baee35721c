"""LabProvider: one build on a worker for every caller, a cancellable wait, reset and failure."""
from __future__ import annotations

import threading

import pytest

from app.lab_provider import LabProvider
from core.errors import RoboCalError


@pytest.fixture
def gated_build(monkeypatch):
    """build_lab that waits for `gate` and records what it was asked for and on which thread."""
    gate, calls = threading.Event(), []

    def build(robot, seed, noise):
        calls.append((robot, seed, noise, threading.current_thread()))
        gate.wait(5)
        return f"lab of {robot}"
    monkeypatch.setattr("app.lab_provider.build_lab", build)
    return gate, calls


@pytest.fixture
def labs(qtbot):
    provider = LabProvider(lambda: ("ur5", 7, 0.5))
    yield provider
    provider.close()


def test_one_build_off_the_gui_thread_and_a_cancelled_wait_is_never_called(labs, gated_build, qtbot):
    gate, calls = gated_build
    got = []
    stereo = labs.when_ready(lambda lab: got.append(("stereo", lab)))
    marker = labs.when_ready(lambda lab: got.append(("marker", lab)))
    assert labs.building and labs.current is None
    stereo.cancel()
    with qtbot.waitSignal(labs.changed) as changed:
        gate.set()
    assert changed.args == ["lab of ur5"] and got == [("marker", "lab of ur5")]
    assert len(calls) == 1 and calls[0][:3] == ("ur5", 7, 0.5) and calls[0][3] is not threading.main_thread()
    marker.cancel()                                         # after the fact: nothing happens
    labs.when_ready(lambda lab: got.append(("poses", lab)))
    assert got[-1] == ("poses", "lab of ur5") and len(calls) == 1     # built: at once


def test_reset_during_the_build_tells_the_waiting_and_drops_its_lab(labs, gated_build, qtbot):
    gate, calls = gated_build
    got, errors = [], []
    labs.when_ready(got.append, errors.append)
    labs.reset("the robot changed")
    assert errors == ["the robot changed"] and not labs.building
    with qtbot.waitSignal(labs._runner.taskFinished):
        gate.set()
    assert got == [] and labs.current is None


def test_a_failed_build_reaches_on_error_and_ready_now_raises(labs, monkeypatch, qtbot):
    def broken(robot, seed, noise):
        raise RoboCalError("no robot model", source="robot.json")
    monkeypatch.setattr("app.lab_provider.build_lab", broken)
    errors = []
    with qtbot.waitSignal(labs._runner.taskFinished):
        labs.when_ready(lambda lab: pytest.fail("no lab"), errors.append)
    assert errors == ["robot.json: no robot model"]
    with pytest.raises(RoboCalError, match="no robot model"):
        labs.ready_now()
