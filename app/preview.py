"""Live previews of the two cameras without blocking the GUI: a worker thread grabs from the
chosen cameras (app.hardware.LiveCameras) and keeps only the newest pair, shrunk to the
preview width; a GUI timer shows it when a new one is there. Frames the GUI has no time for
are dropped, never queued. An optional `check(left, right)` runs on the worker on every pair
grabbed (full frames); the pair shown last, full frames and check answer, stays in `latest`
(what the technician sees is what a capture saves).
"""
from __future__ import annotations

import threading
import time
from dataclasses import dataclass
from typing import Callable

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


@dataclass(frozen=True)
class PreviewPair:
    """One pair the worker grabbed: `seq` counts from 1 since `start()`; `left`, `right` the
    full frames (read-only), `small` the two shrunk for showing, `answer` what `check` said
    of this very pair (None without a check)."""

    seq: int
    left: np.ndarray
    right: np.ndarray
    small: tuple[np.ndarray, np.ndarray]
    answer: object = None


class PreviewPump(QObject):
    """`framesReady(left, right)` on the GUI thread with the newest shrunk pair;
    `failed(message)` when the cameras stop giving images. `grabbed` counts the pairs the
    worker took, `shown` those shown (the others were dropped); `fps()` is the shown rate
    since `start()`. `max_fps` paces the worker (0: as fast as the cameras give frames).
    `latest`: the PreviewPair shown last (GUI thread; None before the first and once stopped).
    With `check`, `checked(PreviewPair)` follows each `framesReady` (the check runs on the
    worker: a slow check drops frames, it never blocks the GUI)."""

    framesReady = Signal(object, object)
    checked = Signal(object)
    failed = Signal(str)

    def __init__(self, cameras, parent: QObject | None = None, *, width: int = PREVIEW_WIDTH,
                 max_fps: float = MAX_FPS, check: Callable[[np.ndarray, np.ndarray], object] | None = None):
        super().__init__(parent)
        self.cameras = cameras
        self.check = check
        self.width = int(width)
        self.max_fps = float(max_fps)
        self.shown = 0
        self.grabbed = 0
        self.latest: PreviewPair | None = None
        self._newest: PreviewPair | None = None      # the worker's, not shown yet
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
        self.latest, self._newest, self._error = None, None, None
        self._started = time.perf_counter()
        self._thread = threading.Thread(target=self._grab_loop, name="camera-preview", daemon=True)
        self._thread.start()
        self._timer.start()

    def stop(self) -> None:
        """Stop grabbing (waits for the worker's current grab and check) and showing."""
        self._timer.stop()
        thread, self._thread = self._thread, None
        if thread is not None:
            self._halt.set()
            thread.join(timeout=5.0)
        self.latest = None

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
                for image in (left, right):
                    image.flags.writeable = False      # the pair checked is the pair saved
                answer = self.check(left, right) if self.check is not None else None
            except RoboCalError as exc:
                with self._lock:
                    self._error = exc.message
                return
            except (cv2.error, ValueError, MemoryError) as exc:     # a frame OpenCV cannot handle
                with self._lock:
                    self._error = f"the live view stopped: a camera frame could not be processed ({exc})"
                return
            seq += 1
            pair = PreviewPair(seq, left, right, (shrink(left, self.width), shrink(right, self.width)), answer)
            with self._lock:
                self._newest = pair
                self.grabbed = seq
            rest = period - (time.perf_counter() - t0)
            if rest > 0:
                self._halt.wait(rest)

    def _tick(self) -> None:            # GUI thread
        with self._lock:
            newest, error = self._newest, self._error
        if newest is not None and newest.seq != self._seen:
            self._seen = newest.seq
            self.shown += 1
            self.latest = newest
            self.framesReady.emit(*newest.small)
            if self.check is not None:
                self.checked.emit(newest)
        if error is not None:
            self.stop()
            self.failed.emit(error)
