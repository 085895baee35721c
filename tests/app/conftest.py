"""Fixtures shared by the wizard's tests (tests/conftest.py adds the leak guard)."""
import pytest
from PySide6.QtWidgets import QMessageBox

from tests.app.demo_walk import walk_the_demo
from tests.session_cache import create_labs_once


@pytest.fixture(autouse=True)
def _virtual_labs_built_once(monkeypatch):
    """A virtual lab is built once per session (~0.3 s each time the wizard or a command built it);
    every test gets its own copy (tests/session_cache.py). VirtualLab.create itself is tested
    in tests/core/virtual_lab."""
    create_labs_once(monkeypatch)


@pytest.fixture
def boxes(monkeypatch):
    """Message boxes recorded as (kind, title, text) instead of shown (they would block the test)."""
    shown = []
    for kind in ("critical", "warning", "information"):
        monkeypatch.setattr(QMessageBox, kind,
                            lambda parent, title, text, *a, _k=kind, **kw: shown.append((_k, title, text)))
    return shown


@pytest.fixture(scope="session")
def demo_walk(qapp, tmp_path_factory):
    """The classroom demo walked once by the autopilot, in-process (tests/app/demo_walk.py): a
    DemoWalk with the window (hidden; a test shows it and hides it again) and how the walk ended."""
    yield from walk_the_demo(tmp_path_factory.mktemp("demo"))
