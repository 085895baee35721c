"""PageTask: one task per page, progress row, Cancel, failures and stale results."""
from __future__ import annotations

import threading

import pytest

from app.pages.base import WizardPage
from app.pages.steps import Step
from app.state import WizardState
from app.worker import TaskRunner
from core.errors import RoboCalError
from core.task import Monitor


class Page(WizardPage):
    step = Step.EXPORT

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self.busy_seen = []
        self.autopilot_said = []
        self._autopilot_done = lambda ok, message="": self.autopilot_said.append((ok, message))

    def on_busy_changed(self):
        self.busy_seen.append(self.task.busy)


@pytest.fixture
def page(qtbot):
    state, tasks = WizardState(), TaskRunner()
    p = Page(state, tasks)
    qtbot.addWidget(p)
    yield p
    tasks.shutdown()
    state.close()


def work(x, *, progress=None, cancelled=None):
    Monitor(progress, cancelled).step(0.5, "half way")
    return 2 * x


def test_result_then_next_step_and_busy_hook(page, qtbot):
    got = []
    row = page.task.progress_row()
    assert page.task.start(work, 21, on_done=got.append, then=lambda: got.append("then"), status="Working…")
    assert page.task.busy and row.cancel_button.isEnabled() and page.status.text() == "Working…"
    qtbot.waitUntil(lambda: not page.task.busy, timeout=5000)
    assert got == [42, "then"] and page.busy_seen == [True, False] and not row.cancel_button.isEnabled()


def test_one_task_at_a_time(page, qtbot):
    gate = threading.Event()
    assert page.task.start(lambda: gate.wait(5), on_done=lambda _: None)
    assert not page.task.start(work, 1, on_done=lambda _: None)
    assert "Busy" in page.status.text()
    gate.set()
    qtbot.waitUntil(lambda: not page.task.busy, timeout=5000)


def test_failure_and_a_refusing_on_done_reach_the_status_line_and_the_autopilot(page, qtbot):
    def bad():
        raise RoboCalError("the board was not found", source="left01.png")
    page.task.start(bad, on_done=lambda _: None)
    qtbot.waitUntil(lambda: not page.task.busy, timeout=5000)
    assert page.status.text().startswith("✗ ") and "board was not found" in page.status.text()
    assert page.autopilot_said[-1][0] is False

    def refuse(_):
        raise RoboCalError("too few pairs")
    page.task.start(work, 1, on_done=refuse, then=lambda: pytest.fail("then after a refusal"))
    qtbot.waitUntil(lambda: not page.task.busy, timeout=5000)
    assert page.status.text() == "✗ too few pairs"


def test_cancel_from_the_progress_row(page, qtbot):
    def endless(*, progress=None, cancelled=None):
        m = Monitor(progress, cancelled)
        while True:
            m.step(0.1, "waiting")
            threading.Event().wait(0.01)
    page.task.start(endless, on_done=lambda _: pytest.fail("no result after Cancel"))
    page.task.progress_row().cancel_button.click()
    qtbot.waitUntil(lambda: not page.task.busy, timeout=5000)
    assert page.status.text() == "Cancelled." and page.autopilot_said[-1] == (False, "cancelled")


def test_a_forgotten_task_delivers_nothing(page, qtbot):
    gate, got = threading.Event(), []
    page.task.start(lambda: gate.wait(5) and 1, on_done=got.append)
    page.task.forget()
    assert not page.task.busy
    gate.set()
    qtbot.waitUntil(lambda: not page.task.runner.busy, timeout=5000)
    qtbot.wait(20)
    assert got == []


def test_start_with_lab_waits_for_the_one_lab_build(page, qtbot, monkeypatch):
    built = threading.Event()

    def slow_lab(robot, seed, noise):
        built.wait(5)
        return "the lab"
    monkeypatch.setattr("app.lab_provider.build_lab", slow_lab)
    got = []
    assert page.task.start_with_lab(lambda *, lab: f"used {lab}", on_done=got.append)
    assert page.task.busy and "building the virtual lab" in page.task.progress_row().bar.format()
    assert not page.task.start(work, 1, on_done=got.append)          # one thing at a time
    built.set()
    qtbot.waitUntil(lambda: got == ["used the lab"] and not page.task.busy, timeout=5000)
    assert page.busy_seen[0] is True and page.busy_seen[-1] is False


def test_following_the_lab_says_it_is_being_built(page, qtbot, monkeypatch):
    """A page that waits for the lab before its own job (the Stereo page's virtual pairs) shows the
    build in its progress row, then hands over to the job."""
    gate = threading.Event()
    monkeypatch.setattr("app.lab_provider.build_lab", lambda robot, seed, noise: gate.wait(5) and "lab")
    got = []
    page.task.follow_lab(lambda lab: page.task.start(lambda: f"pairs of the {lab}", on_done=got.append,
                                                     label="Rendering virtual-lab pairs"), page.on_failed)
    assert page.task.busy and page.task.progress_row().bar.format().startswith("building the virtual lab")
    gate.set()
    qtbot.waitUntil(lambda: got == ["pairs of the lab"] and not page.task.busy, timeout=5000)


def test_cancel_and_forget_while_waiting_for_the_lab(page, qtbot, monkeypatch):
    gate = threading.Event()
    monkeypatch.setattr("app.lab_provider.build_lab", lambda robot, seed, noise: gate.wait(5) and "lab")
    page.task.start_with_lab(lambda *, lab: pytest.fail("started after Cancel"), on_done=lambda _: None)
    page.task.cancel()
    assert not page.task.busy and page.status.text() == "Cancelled."
    page.task.start_with_lab(lambda *, lab: pytest.fail("started after the robot changed"), on_done=lambda _: None)
    page.task.forget()
    assert not page.task.busy
    gate.set()
    qtbot.waitUntil(lambda: page.state.labs.built, timeout=5000)       # the build itself goes on for other pages
    qtbot.wait(20)


def test_with_lab_runs_its_callback_once_the_lab_exists_and_at_once_after(page, qtbot, monkeypatch):
    gate = threading.Event()
    monkeypatch.setattr("app.lab_provider.build_lab", lambda robot, seed, noise: gate.wait(5) and "lab")
    seen = []
    assert page.task.with_lab(lambda lab: seen.append((lab, page.task.busy)))
    assert page.task.busy and seen == []
    gate.set()
    qtbot.waitUntil(lambda: seen == [("lab", False)], timeout=5000)     # not busy when the callback runs
    assert page.task.with_lab(lambda lab: seen.append((lab, page.task.busy)))
    assert seen[-1] == ("lab", False) and len(seen) == 2                # the lab exists: at once


def test_a_failed_lab_build_reaches_on_failed(page, qtbot, monkeypatch):
    def broken(robot, seed, noise):
        raise RoboCalError("no robot model", source="robot.json")
    monkeypatch.setattr("app.lab_provider.build_lab", broken)
    page.task.with_lab(lambda lab: pytest.fail("called without a lab"))
    qtbot.waitUntil(lambda: not page.task.busy, timeout=5000)
    assert "no robot model" in page.status.text() and page.autopilot_said[-1][0] is False
