"""The Stereo page's live view of the cameras opened on the Setup page: both previews side by
side (app.preview.PreviewPump: a worker grabs, the newest pair is shown, the others dropped),
a quick board check of every pair on that worker (core.stereo.detection.board_in_view,
the page's board), and under each image whether that camera sees the board.

What you see is what you save: the pair shown last is kept with its check (`pump.latest`);
`ready_pair()` is that very pair while the board is in both of its images and it was not
saved yet, and a capture saves it instead of grabbing again. Shown only with real cameras,
running only while visible."""
from __future__ import annotations

from typing import Callable

from PySide6.QtCore import Signal
from PySide6.QtWidgets import QGroupBox, QHBoxLayout, QLabel, QVBoxLayout, QWidget

from app.preview import PreviewPair, PreviewPump
from core.stereo.board import Board
from core.stereo.detection import board_in_view
from widgets.stereo_preview import StereoPreview

PREVIEW_WIDTH = 320          # px per camera: a small view beside the pairs
SEEN = "<span style='color:#188038'><b>✓ board seen</b></span>"
NOT_SEEN = "<span style='color:#c5221f'><b>✗ no board</b></span>"
WAITING = "<span style='color:#5f6368'>waiting for a frame…</span>"


class LivePreviewPanel(QGroupBox):
    """`board`: returns the board to look for (read on the worker for every pair).
    `readyChanged(bool)`: a pair to capture is there (`ready_pair()`), or no longer."""

    readyChanged = Signal(bool)

    def __init__(self, state, board: Callable[[], Board], parent: QWidget | None = None):
        super().__init__("Live cameras", parent)
        self.state = state
        self.board = board
        self.pump: PreviewPump | None = None
        self._saved_seq = 0                  # the pair of this pump run saved last (0: none)
        self._ready = False
        self.preview = StereoPreview(min_width=200)
        self.preview.setFixedHeight(190)
        self.left_label, self.right_label = QLabel(WAITING), QLabel(WAITING)
        self.left_label.setObjectName("leftBoardLabel")
        self.right_label.setObjectName("rightBoardLabel")
        marks = QHBoxLayout()
        marks.setContentsMargins(0, 0, 0, 0)
        for side, label in (("Left", self.left_label), ("Right", self.right_label)):
            marks.addWidget(QLabel(f"{side}:"))
            marks.addWidget(label, 1)
        layout = QVBoxLayout(self)
        layout.setContentsMargins(6, 4, 6, 4)
        layout.setSpacing(2)
        layout.addWidget(self.preview)
        layout.addLayout(marks)
        state.hardware.camerasChanged.connect(self._cameras_changed)
        self.setVisible(state.hardware.cameras is not None)

    @property
    def seen(self) -> tuple[bool, bool] | None:
        """(left, right) sees the board, of the pair shown last; None: no pair shown."""
        latest = self.pump.latest if self.pump is not None else None
        return None if latest is None else latest.answer

    def ready_pair(self) -> PreviewPair | None:
        """The pair shown last when the board is in both images and it was not saved yet."""
        latest = self.pump.latest if self.pump is not None else None
        if latest is None or latest.answer != (True, True) or latest.seq == self._saved_seq:
            return None
        return latest

    def saved(self, pair: PreviewPair) -> None:
        """`pair` is being saved: no second capture of it."""
        self._saved_seq = pair.seq
        self._update()

    # -- the pump ---------------------------------------------------------------------------
    def start(self) -> None:
        cams = self.state.hardware.cameras
        if cams is None or self.pump is not None:
            return
        self._saved_seq = 0
        self.pump = PreviewPump(cams, self, width=PREVIEW_WIDTH, check=self._check)
        self.pump.framesReady.connect(self.preview.show_pair)
        self.pump.checked.connect(self._update)
        self.pump.failed.connect(self._failed)
        self.pump.start()

    def stop(self) -> None:
        if self.pump is not None:
            self.pump.stop()
            self.pump.deleteLater()
            self.pump = None
        self._update()

    def _check(self, left, right) -> tuple[bool, bool]:       # worker thread
        board = self.board()
        return board_in_view(left, board), board_in_view(right, board)

    # -- display ----------------------------------------------------------------------------
    def _update(self, *_) -> None:
        seen = self.seen
        for label, ok in zip((self.left_label, self.right_label), seen or (None, None)):
            label.setText(WAITING if ok is None else SEEN if ok else NOT_SEEN)
        if self.pump is not None and self.pump.shown and self.pump.shown % 10 == 0:
            self.preview.set_caption(f"{self.pump.fps():.1f} frames/s")
        ready = self.ready_pair() is not None
        if ready != self._ready:
            self._ready = ready
            self.readyChanged.emit(ready)

    def _failed(self, message: str) -> None:
        self.stop()
        self.preview.clear()
        self.preview.set_caption(f"The preview stopped: {message}")

    def _cameras_changed(self, cams) -> None:
        self.stop()
        self.preview.clear()
        self.preview.set_caption("")
        self.setVisible(cams is not None)
        if cams is not None and self.isVisible():
            self.start()

    def showEvent(self, event) -> None:
        super().showEvent(event)
        self.start()

    def hideEvent(self, event) -> None:
        super().hideEvent(event)
        self.stop()
