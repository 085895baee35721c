"""The Stereo step's model, plain Python (no Qt): the camera model the technician chooses
(options, core.stereo.fit.CalibrationOptions), the checkerboard pairs on the page with the
board they show (mm), and the calibration made from them (result,
core.stereo.calibration.StereoCalibrationResult) with the stereo.yaml it was saved as.

Events (`on(event, listener)`): "added" (the new pairs), "removed" (their keys), "cleared",
"board" (the Board), "pairs" (pairs, verdicts or board changed: redraw them), "options" and
"result" (StepModel's)."""
from __future__ import annotations

from itertools import count
from pathlib import Path
from typing import Sequence

from app.jobs.stereo import AddedPair
from app.pages.step_model import StepModel
from core.stereo.board import Board
from core.stereo.calibration import StereoCalibrationResult
from core.stereo.coverage import Coverage, coverage
from core.stereo.fit import CalibrationOptions
from core.stereo.screening import DetectionResult, screen_pairs


class StereoModel(StepModel[CalibrationOptions, StereoCalibrationResult]):
    """The pairs (`items`, in the order added, each with a key of its thumbnail), their
    screened detections, the board, the calibration and whether the pairs changed since
    (`stale`), and the project's stereo.yaml (`saved_path`)."""

    def __init__(self, board: Board, options: CalibrationOptions | None = None):
        super().__init__(options or CalibrationOptions())
        self.board = board
        self.items: list[AddedPair] = []
        self.detections: DetectionResult | None = None      # the items' detections, screened together
        self.stale = False                                   # pairs changed since the calibration
        self.saved_path: Path | None = None                  # stereo.yaml of this session or of the project
        self.ignored_files: list[str] = []                   # not images, in the folders added last
        self._keys = count()

    # -- what the pairs give ------------------------------------------------------------------
    def usable(self) -> list[AddedPair]:
        """The accepted pairs not dropped by the technician."""
        return [a for a in self.items if a.detection.accepted and not a.excluded]

    def coverage(self) -> Coverage:
        """The ROS-style coverage of the usable pairs."""
        return coverage([a.detection for a in self.usable()])

    def current_result(self) -> StereoCalibrationResult | None:
        """The calibration while it is still the calibration of these pairs."""
        return None if self.stale else self.result

    # -- changing the pairs ---------------------------------------------------------------------
    def add(self, added: Sequence[AddedPair]) -> None:
        """New pairs (from a worker): keyed, screened again with the others."""
        for a in added:
            a.key = next(self._keys)
            self.items.append(a)
        self.emit("added", list(added))
        self.changed()

    def remove(self, keys: Sequence[int]) -> None:
        gone = set(keys)
        removed = [a.key for a in self.items if a.key in gone]
        self.items = [a for a in self.items if a.key not in gone]
        self.emit("removed", removed)
        self.changed()

    def clear(self) -> None:
        self.take_all()
        self.changed()

    def take_all(self) -> list[AddedPair]:
        """Remove every pair without screening (they are detected again next); returns them."""
        taken, self.items = self.items, []
        self.emit("cleared")
        return taken

    def exclude(self, detections: Sequence[object]) -> None:
        """Drop the pairs of these detections (by identity: pairs added or removed since a
        calibration renumber the others)."""
        objects = {id(d) for d in detections}
        for a in self.items:
            if id(a.detection) in objects:
                a.excluded = True
        self.changed()

    def restore(self) -> None:
        """Bring back every dropped pair."""
        for a in self.items:
            a.excluded = False
        self.changed()

    def set_board(self, board: Board) -> None:
        self.board = board
        self.emit("board", board)

    def changed(self) -> None:
        """Pairs or board changed: screen all pairs again; a calibration is now stale."""
        dets = [a.detection for a in self.items]
        self.detections = screen_pairs(dets, self.board) if dets else None
        if self.result is not None:
            self.stale = True
        self.emit("pairs")

    def screened(self) -> DetectionResult:
        """The detections screened again, as a calibration takes them."""
        self.detections = screen_pairs([a.detection for a in self.items], self.board)
        return self.detections

    # -- the calibration ----------------------------------------------------------------------
    def set_result(self, result: StereoCalibrationResult | None) -> None:
        """A calibration of the pairs as they are now (None: none)."""
        self.stale = False
        super().set_result(result)

    def reset(self, board: Board) -> None:
        """Another project: no pairs, no calibration, nothing saved; `board` (listeners hear of the
        cleared pairs and the board; of the result when it is set next)."""
        self.take_all()
        self.detections = None
        self.result = None
        self.stale = False
        self.saved_path = None
        self.ignored_files = []
        self.set_board(board)
