"""Windows the tests open and close: the wizard on a new project with the 6R arm chosen, a modal
dialog over it whose text field has the keyboard, and closing a window as the autopilot does."""
from __future__ import annotations

from pathlib import Path

from PySide6.QtWidgets import QApplication, QDialog, QLineEdit, QVBoxLayout

from app import messages
from app.main_window import MainWindow
from app.state import WizardState


def window_on_project(qtbot, folder: Path) -> MainWindow:
    """The wizard shown at 1400x900 on a new project in `folder`, the educational 6R arm chosen
    (close it after the test)."""
    win = MainWindow(WizardState())
    qtbot.addWidget(win)
    win.resize(1400, 900)
    win.show()
    qtbot.waitExposed(win)
    win.state.new_project(folder)
    win.state.choose_preset("educational_6r")
    return win


def modal_dialog(window, qtbot, field_type: type[QLineEdit] = QLineEdit) -> tuple[QDialog, QLineEdit]:
    """A modal dialog over `window` with a text field (of `field_type`) that has the keyboard:
    (dialog, field)."""
    dialog = QDialog(window)
    field = field_type(dialog)
    QVBoxLayout(dialog).addWidget(field)
    dialog.setModal(True)
    qtbot.addWidget(dialog)
    dialog.show()
    qtbot.waitExposed(dialog)
    dialog.activateWindow()
    field.setFocus()
    qtbot.waitUntil(lambda: QApplication.activeModalWidget() is dialog, timeout=5000)
    return dialog, field


def close_window(win) -> bool:
    """Close `win`; a demo (temporary) project with results would ask whether to keep them in a
    modal box, and the test answers as the autopilot does (quit without saving)."""
    messages.set_non_interactive(True)
    try:
        return win.close()
    finally:
        messages.set_non_interactive(False)
