"""A progress bar with its Cancel button: the row a page shows while work runs on a worker."""
from __future__ import annotations

from PySide6.QtCore import QTimer, Signal
from PySide6.QtWidgets import QHBoxLayout, QProgressBar, QPushButton, QScrollArea, QWidget


class ProgressRow(QWidget):
    """Progress bar (0–100 %, with the worker's message) and a Cancel button.

    `set_progress(fraction, message)` updates the bar; `set_busy(busy)` enables Cancel (and scrolls
    the row into sight when it becomes busy inside scrolling boxes);
    `reset()` empties the bar. Signal: `cancelRequested()` when Cancel is clicked.
    """

    cancelRequested = Signal()

    def __init__(self, parent: QWidget | None = None, *, cancel_text: str = "Cancel"):
        super().__init__(parent)
        self.bar = QProgressBar()
        self.bar.setRange(0, 1000)
        self.bar.setTextVisible(True)
        self.bar.setFormat("%p%")
        self.cancel_button = QPushButton(cancel_text)
        self.cancel_button.setObjectName("cancelButton")
        self.cancel_button.setEnabled(False)
        self.cancel_button.clicked.connect(self.cancelRequested)
        layout = QHBoxLayout(self)
        layout.setContentsMargins(0, 0, 0, 0)
        layout.addWidget(self.bar, 1)
        layout.addWidget(self.cancel_button)

    def set_progress(self, fraction: float, message: str = "") -> None:
        """Show `fraction` (0–1) of the work done, with the worker's message."""
        self.bar.setValue(int(round(1000 * min(max(fraction, 0.0), 1.0))))
        self.bar.setFormat(f"{message.replace('%', '%%')}  %p%" if message else "%p%")

    def set_busy(self, busy: bool) -> None:
        """Enable Cancel while busy; a row that becomes busy inside scrolling boxes scrolls into sight."""
        became_busy = busy and not self.cancel_button.isEnabled()
        self.cancel_button.setEnabled(busy)
        if became_busy:                 # once the page has laid out what it shows while busy
            QTimer.singleShot(0, self, self._scroll_into_sight)

    def _scroll_into_sight(self) -> None:
        box = self.parentWidget()
        while box is not None:
            if isinstance(box, QScrollArea):
                box.ensureWidgetVisible(self)
            box = box.parentWidget()

    def reset(self) -> None:
        self.bar.setValue(0)
        self.bar.setFormat("%p%")
