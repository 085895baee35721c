"""Live previews of the two cameras without blocking the GUI: a worker thread grabs from the
chosen cameras (app.hardware.LiveCameras) and keeps only the newest pair, shrunk to the
preview width; a GUI timer shows it when a new one is there. Frames the GUI has no time for
are dropped, never queued.
"""
from __future__ import annotations

import threading
import time

import cv2
import numpy as np
from PySide6.QtCore import QObject, QTimer, Signal

from core.errors import RoboCalError

PREVIEW_WIDTH = 480          # px per camera
MAX_FPS = 30.0               # the worker's pace for video files and image folders
TIMER_MS = 30                # how often the GUI looks for a new pair


def shrink(image: np.ndarray, width: int) -> np.ndarray:
    """`image` scaled to `width` px (aspect kept), as 8-bit; grey stays grey."""
    if image.dtype != np.uint8:
        image = cv2.convertScaleAbs(image, alpha=255.0 / max(float(image.max()), 1.0))
    h, w = image.shape[:2]
    if w == width:
        return image
    return cv2.resize(image, (width, max(1, round(h * width / w))), interpolation=cv2.INTER_AREA)


class PreviewPump(QObject):
    """`framesReady(left, right)` on the GUI thread with the newest shrunk pair;
    `failed(message)` when the cameras stop giving images. `grabbed` counts the pairs the
    worker took, `shown` those shown (the others were dropped); `fps()` is the shown rate
    since `start()`. `max_fps` paces the worker (0: as fast as the cameras give frames)."""

    framesReady = Signal(object, object)
    failed = Signal(str)

    def __init__(self, cameras, parent: QObject | None = None, *, width: int = PREVIEW_WIDTH,
                 max_fps: float = MAX_FPS):
        super().__init__(parent)
        self.cameras = cameras
        self.width = int(width)
        self.max_fps = float(max_fps)
        self.shown = 0
        self.grabbed = 0
        self._latest = None              # (sequence, left, right)
        self._error: str | None = None
        self._seen = 0
        self._lock = threading.Lock()
        self._halt = threading.Event()
        self._thread: threading.Thread | None = None
        self._started = 0.0
        self._timer = QTimer(self)
        self._timer.setInterval(TIMER_MS)
        self._timer.timeout.connect(self._tick)

    @property
    def running(self) -> bool:
        return self._thread is not None

    def start(self) -> None:
        if self._thread is not None:
            return
        self._halt.clear()
        self.shown = self.grabbed = self._seen = 0
        self._latest, self._error = None, None
        self._started = time.perf_counter()
        self._thread = threading.Thread(target=self._grab_loop, name="camera-preview", daemon=True)
        self._thread.start()
        self._timer.start()

    def stop(self) -> None:
        """Stop grabbing (waits for the worker's current grab) and showing."""
        self._timer.stop()
        thread, self._thread = self._thread, None
        if thread is not None:
            self._halt.set()
            thread.join(timeout=5.0)

    def fps(self) -> float:
        """Pairs shown per second since `start()`."""
        elapsed = time.perf_counter() - self._started
        return self.shown / elapsed if self._started and elapsed > 0 else 0.0

    def _grab_loop(self) -> None:       # worker thread
        period = 1.0 / self.max_fps if self.max_fps > 0 else 0.0
        seq = 0
        while not self._halt.is_set():
            t0 = time.perf_counter()
            try:
                left, right = self.cameras.preview()
            except RoboCalError as exc:
                with self._lock:
                    self._error = exc.message
                return
            pair = (shrink(left, self.width), shrink(right, self.width))
            seq += 1
            with self._lock:
                self._latest = (seq, *pair)
                self.grabbed = seq
            rest = period - (time.perf_counter() - t0)
            if rest > 0:
                self._halt.wait(rest)

    def _tick(self) -> None:            # GUI thread
        with self._lock:
            latest, error = self._latest, self._error
        if latest is not None and latest[0] != self._seen:
            self._seen = latest[0]
            self.shown += 1
            self.framesReady.emit(latest[1], latest[2])
        if error is not None:
            self.stop()
            self.failed.emit(error)
