"""Closing a main window in a test: a demo (temporary) project with results would ask whether
to keep them in a modal box; a test answers as the autopilot does (quit without saving)."""
from __future__ import annotations

from app import messages


def close_window(win) -> bool:
    messages.set_non_interactive(True)
    try:
        return win.close()
    finally:
        messages.set_non_interactive(False)
