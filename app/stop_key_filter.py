"""The Stop keys where the main window's shortcuts do not reach: a modal or file dialog, a menu,
another window of RoboCal. One key press stops the robot once, however long its delivery takes."""
from __future__ import annotations

from typing import Callable

import shiboken6
from PySide6.QtCore import QEvent, QObject, Qt
from PySide6.QtGui import QKeyEvent, QWindow
from PySide6.QtWidgets import QApplication, QMenu, QWidget


class KeyPressOnce:
    """Tells a key press's first delivery from the later steps of the same press.

    Qt hands one key press to several receivers, with the same event object: the window
    system's press first reaches the window (a QWindow), which passes it to its focus widget; a
    widget that leaves it unhandled passes it on to its parent, up to its dialog. An application
    event filter sees every step. A step is recognised by what it is, not by the time since the
    last one (a slow robot stop or a busy computer would make it look like a new press): the same
    event (object, timestamp, key, modifiers) going on from a window to a widget or from a widget
    to one of its ancestors. A new press from the window system has a timestamp of its own and
    starts at a window; a synthesised one (timestamp 0, often at the same address) starts again at
    the focus widget, not above the widget where the last press ended."""

    def __init__(self):
        self._last: tuple[tuple, QObject] | None = None    # (press identity, receiver) of the last step seen

    def first_delivery(self, receiver: QObject, event: QKeyEvent) -> bool:
        """True for a new press; False for a step of the press seen last (remembers this step)."""
        identity = (shiboken6.getCppPointer(event)[0], event.timestamp(), event.key(), event.modifiers())
        last, self._last = self._last, (identity, receiver)
        return last is None or last[0] != identity or not _passes_on(last[1], receiver)


def _passes_on(previous: QObject, receiver: QObject) -> bool:
    """A key event delivered to `previous` goes on to `receiver`: from a window to a widget, or
    from a widget up to one of its ancestors."""
    if not isinstance(receiver, QWidget) or not shiboken6.isValid(previous):
        return False
    if isinstance(previous, QWindow):
        handle = receiver.window().windowHandle()
        return handle is not None and shiboken6.getCppPointer(handle) == shiboken6.getCppPointer(previous)
    return isinstance(previous, QWidget) and receiver is not previous and receiver.isAncestorOf(previous)


def is_stop_key(event: QKeyEvent, escape_stops: Callable[[], bool]) -> bool:
    """Ctrl+. (on the keypad too), or Esc when `escape_stops()` says so (asked for Esc only)."""
    key, mods = event.key(), event.modifiers() & ~Qt.KeyboardModifier.KeypadModifier
    return ((key == Qt.Key.Key_Escape and mods == Qt.KeyboardModifier.NoModifier and escape_stops())
            or (key == Qt.Key.Key_Period and mods == Qt.KeyboardModifier.ControlModifier))


class StopKeyElsewhere(QObject):
    """The window's Stop shortcuts act while the main window has the keyboard. Elsewhere — a
    modal or file dialog, a menu, another window of RoboCal, where Qt blocks the window's
    shortcuts — Ctrl+. still stops the robot, and Esc does only while a motion is running: there
    Esc first means "close this dialog", and stopping a robot that stands still would be a
    surprise. The dialog or menu gets the key too. Installed on the application by `install()`,
    removed by `remove()`."""

    def __init__(self, window: QWidget, motion_running: Callable[[], bool], stop: Callable[[], None]):
        super().__init__(window)
        self.window = window
        self.motion_running = motion_running
        self.stop = stop
        self.presses = KeyPressOnce()

    def install(self) -> None:
        QApplication.instance().installEventFilter(self)

    def remove(self) -> None:
        QApplication.instance().removeEventFilter(self)

    def eventFilter(self, obj, event) -> bool:
        if event.type() != QEvent.Type.KeyPress or not isinstance(event, QKeyEvent) or event.isAutoRepeat():
            return False
        elsewhere = (QApplication.activeModalWidget() is not None
                     or isinstance(QApplication.activePopupWidget(), QMenu)    # menus eat Esc too
                     or QApplication.activeWindow() is not self.window)
        if (elsewhere and is_stop_key(event, self.motion_running)
                and self.presses.first_delivery(obj, event)):
            self.stop()
        return False
