"""The Stereo page's "Capture from cameras" with the cameras opened on the Setup page: the pair
the live preview showed and checked (live_preview.py), saved as checkerboard/left|right/
pair_NNN.png in the project (numbered after the pairs already there), then detected like the
other pairs, in one worker job (no Qt). Nothing is grabbed again: the pair saved is the pair
the technician saw."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from app.jobs.stereo import detect_files, next_free_number
from app.jobs.stereo_pairs import Shown
from core.files import atomic_write_bytes
from core.images import encode_png
from core.stereo.board import Board
from core.task import Monitor


def save_checkerboard_pair(left: np.ndarray, right: np.ndarray, folder: Path, board: Board, *,
                           shown: Shown, progress=None, cancelled=None) -> int:
    """Write the camera images `left`, `right` into `folder`/left and `folder`/right as the next
    pair_NNN.png (lossless), detect the board in them and hand the pair to `shown` (on the
    worker thread, as app/jobs/stereo_pairs.py's runs do). Returns 1, the pairs added."""
    monitor = Monitor(progress, cancelled)
    monitor.step(0.0, "saving the pair")
    n = next_free_number(folder)
    paths = (folder / "left" / f"pair_{n:03d}.png", folder / "right" / f"pair_{n:03d}.png")
    for image, path in zip((left, right), paths):
        atomic_write_bytes(path, encode_png(image, "the camera image", path))
    shown(detect_files([paths], board, "cameras", progress=monitor.sub(0.3, 1.0), cancelled=cancelled))
    return 1
