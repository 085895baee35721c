"""Errors shown to the user: a message box in the wizard, one line on stderr when nobody is
there to click (autopilot, screenshots runs). Also the top-level exception hook."""
from __future__ import annotations

import sys
import traceback

from PySide6.QtWidgets import QMessageBox, QWidget

#: True while the wizard runs on its own (--autopilot): no modal box may block it.
NON_INTERACTIVE = False


def set_non_interactive(value: bool) -> None:
    global NON_INTERACTIVE
    NON_INTERACTIVE = bool(value)


def show_error(parent: QWidget | None, message: str, title: str = "RoboCal") -> None:
    """One clear message. Tests patch `QMessageBox.critical` to see it without blocking."""
    if NON_INTERACTIVE:
        sys.stderr.write(f"robocal gui: {title}: {message}\n")
        return
    QMessageBox.critical(parent, title, message)


def show_info(parent: QWidget | None, message: str, title: str = "RoboCal") -> None:
    if NON_INTERACTIVE:
        sys.stdout.write(f"robocal gui: {message}\n")
        return
    QMessageBox.information(parent, title, message)


def confirm(parent: QWidget | None, question: str, title: str = "RoboCal", *, yes: str = "Yes",
            non_interactive_answer: bool = True) -> bool:
    """Ask a yes/no question (No is the default button). When nobody is there to click
    (autopilot, tests) the question goes to stderr and `non_interactive_answer` is taken."""
    if NON_INTERACTIVE:
        sys.stderr.write(f"robocal gui: {title}: {question} -> {'yes' if non_interactive_answer else 'no'}\n")
        return bool(non_interactive_answer)
    box = QMessageBox(QMessageBox.Icon.Question, title, question, parent=parent)
    ok = box.addButton(yes, QMessageBox.ButtonRole.AcceptRole)
    box.setDefaultButton(box.addButton(QMessageBox.StandardButton.No))
    box.exec()
    return box.clickedButton() is ok


def choose(parent: QWidget | None, question: str, answers: list[str], title: str = "RoboCal", *,
           non_interactive_answer: str) -> str | None:
    """Ask `question` with one button per answer (the first is the default; Cancel is added):
    the answer chosen, or None for Cancel. When nobody is there to click (autopilot, tests) the
    question goes to stderr and `non_interactive_answer` is taken."""
    if NON_INTERACTIVE:
        sys.stderr.write(f"robocal gui: {title}: {question} -> {non_interactive_answer}\n")
        return non_interactive_answer
    box = QMessageBox(QMessageBox.Icon.Question, title, question, parent=parent)
    buttons = {box.addButton(a, QMessageBox.ButtonRole.AcceptRole): a for a in answers}
    box.addButton(QMessageBox.StandardButton.Cancel)
    box.setDefaultButton(next(iter(buttons)))
    box.exec()
    return buttons.get(box.clickedButton())


def install_excepthook(parent_getter=lambda: None, on_fatal=None):
    """Route uncaught exceptions (e.g. in a slot) to a message box instead of killing the app.

    The traceback goes to stderr; the user sees ``Type: message``. When non-interactive,
    `on_fatal(exc)` is called instead (the autopilot fails with exit code 1).
    Returns a function that restores the previous hook."""
    from core.errors import RoboCalError

    previous = sys.excepthook

    def hook(exc_type, exc, tb):
        if issubclass(exc_type, KeyboardInterrupt):
            previous(exc_type, exc, tb)
            return
        if isinstance(exc, RoboCalError):
            text = exc.message
        else:
            text = f"{exc_type.__name__}: {exc}" if str(exc) else exc_type.__name__
            sys.stderr.write("".join(traceback.format_exception(exc_type, exc, tb)))
        if NON_INTERACTIVE:
            sys.stderr.write(f"robocal gui: unexpected error: {text}\n")
            if on_fatal is not None:
                on_fatal(exc)
            return
        try:
            box = QMessageBox(QMessageBox.Icon.Critical, "RoboCal: unexpected error",
                              f"{text}\n\nRoboCal keeps running, but the action that failed did not "
                              "finish. Please report this problem with the details below.",
                              parent=parent_getter())
            box.setDetailedText("".join(traceback.format_exception(exc_type, exc, tb)))
            box.exec()
        except Exception:  # noqa: BLE001 - the hook itself must never raise
            previous(exc_type, exc, tb)

    sys.excepthook = hook

    def restore():
        sys.excepthook = previous

    return restore
