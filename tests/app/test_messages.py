"""Errors reach the user: message boxes when interactive, stderr when the autopilot runs,
and the top-level exception hook instead of a dead app."""
from __future__ import annotations

import sys

import pytest
from PySide6.QtWidgets import QMessageBox

from app import messages
from core.errors import RoboCalError


@pytest.fixture
def hook(monkeypatch):
    restores = []

    def install(**kwargs):
        restore = messages.install_excepthook(**kwargs)
        restores.append(restore)
        return restore

    yield install
    for restore in reversed(restores):
        restore()
    messages.set_non_interactive(False)


def test_show_error_uses_a_message_box(qtbot, monkeypatch):
    shown = []
    monkeypatch.setattr(QMessageBox, "critical", lambda *a: shown.append(a))
    messages.show_error(None, "robot.json: field 'joints': missing", "RoboCal: Setup")
    assert shown == [(None, "RoboCal: Setup", "robot.json: field 'joints': missing")]


def test_show_error_non_interactive_goes_to_stderr(qtbot, monkeypatch, capsys):
    monkeypatch.setattr(QMessageBox, "critical", lambda *a: pytest.fail("a box would block the autopilot"))
    messages.set_non_interactive(True)
    try:
        messages.show_error(None, "no marker", "RoboCal: Marker")
    finally:
        messages.set_non_interactive(False)
    assert capsys.readouterr().err == "robocal gui: RoboCal: Marker: no marker\n"


def test_excepthook_shows_the_error_in_a_box(qtbot, monkeypatch, hook, capsys):
    shown = []
    monkeypatch.setattr(QMessageBox, "exec", lambda box: shown.append((box.text(), box.detailedText())) or 0)
    previous = sys.excepthook
    restore = hook()
    assert sys.excepthook is not previous
    try:
        raise ValueError("bad pixel")
    except ValueError:
        sys.excepthook(*sys.exc_info())
    assert shown and shown[0][0].startswith("ValueError: bad pixel")
    assert "Traceback" in shown[0][1] and "bad pixel" in capsys.readouterr().err
    restore()
    assert sys.excepthook is previous


def test_excepthook_robocal_error_is_its_message(qtbot, monkeypatch, hook):
    shown = []
    monkeypatch.setattr(QMessageBox, "exec", lambda box: shown.append(box.text()) or 0)
    hook()
    sys.excepthook(RoboCalError, RoboCalError("cannot open camera", source="/dev/video0"), None)
    assert shown[0].startswith("/dev/video0: cannot open camera")


def test_excepthook_non_interactive_is_fatal(qtbot, monkeypatch, hook, capsys):
    monkeypatch.setattr(QMessageBox, "exec", lambda box: pytest.fail("no box in autopilot"))
    fatal = []
    hook(on_fatal=fatal.append)
    messages.set_non_interactive(True)
    exc = RuntimeError("slot crashed")
    sys.excepthook(RuntimeError, exc, None)
    assert fatal == [exc]
    assert "unexpected error: RuntimeError: slot crashed" in capsys.readouterr().err
