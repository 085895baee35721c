"""Figures drawn on the GUI thread for a report written on a worker.

pyqtgraph draws with QWidgets and QGraphicsItems (its plots own context menus), which live on
the GUI thread only. A worker that writes a report hands each figure to a `GuiDrawer` made on
the GUI thread and waits for its image, one figure at a time: the GUI stays responsive between
figures (each takes about 0.25 s), and Cancel is honoured while waiting.

    drawer = GuiDrawer()                  # on the GUI thread
    write_report(project, outputs, draw=drawer.draw, ...)   # on a worker
"""
from __future__ import annotations

import threading

from PySide6.QtCore import QObject, QThread, Signal, Slot
from PySide6.QtGui import QImage

from app.report.figures import render_png
from core.errors import Cancelled
from core.report.document import Figure

POLL_S = 0.05


class _Request:
    def __init__(self, fig: Figure):
        self.fig = fig
        self.done = threading.Event()
        self.image: QImage | None = None
        self.error: BaseException | None = None
        self.abandoned = False


class GuiDrawer(QObject):
    """Draws figures on the thread it was made on (the GUI thread)."""

    _requested = Signal(object)

    def __init__(self, parent: QObject | None = None):
        super().__init__(parent)
        self._requested.connect(self._draw)          # queued when emitted from another thread

    def draw(self, fig: Figure, cancelled=None) -> QImage:
        """The figure's image; called from a worker (from the GUI thread it draws at once).
        Raises Cancelled when `cancelled()` becomes True while waiting."""
        if QThread.currentThread() is self.thread():
            return render_png(fig)
        if cancelled is not None and cancelled():
            raise Cancelled()
        request = _Request(fig)
        self._requested.emit(request)
        while not request.done.wait(POLL_S):
            if cancelled is not None and cancelled():
                request.abandoned = True
                raise Cancelled()
        if request.error is not None:
            raise request.error
        return request.image

    @Slot(object)
    def _draw(self, request: _Request) -> None:
        if request.abandoned:
            return
        try:
            request.image = render_png(request.fig)
        except Exception as exc:     # noqa: BLE001 - handed back to the worker, which reports it
            request.error = exc
        finally:
            request.done.set()
