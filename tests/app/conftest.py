"""Fixtures shared by the wizard's tests (tests/conftest.py adds the leak guard)."""
import pytest
from PySide6.QtWidgets import QMessageBox


@pytest.fixture
def boxes(monkeypatch):
    """Message boxes recorded as (kind, title, text) instead of shown (they would block the test)."""
    shown = []
    for kind in ("critical", "warning", "information"):
        monkeypatch.setattr(QMessageBox, kind,
                            lambda parent, title, text, *a, _k=kind, **kw: shown.append((_k, title, text)))
    return shown
