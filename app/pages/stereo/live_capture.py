"""The Stereo page's "Capture from cameras" with the cameras opened on the Setup page: one pair
taken together, saved as checkerboard/left|right/pair_NNN.png in the project (numbered after
the pairs already there), then detected like the other pairs."""
from __future__ import annotations

from functools import partial
from pathlib import Path

import cv2

from app.jobs.stereo import PNG_PARAMS, AddedPair, detect_files, next_free_number
from core.errors import RoboCalError
from core.files import atomic_write_bytes
from core.stereo.board import Board
from core.task import Monitor


def capture_checkerboard_pair(cameras, folder: Path, board: Board, *, progress=None,
                              cancelled=None) -> list[AddedPair]:
    """Capture a pair from `cameras` (app.hardware.LiveCameras), write it into `folder`/left and
    `folder`/right as the next pair_NNN.png, detect the board in it."""
    monitor = Monitor(progress, cancelled)
    monitor.step(0.0, "capturing")
    frames = cameras.capture()
    n = next_free_number(folder)
    paths = (folder / "left" / f"pair_{n:03d}.png", folder / "right" / f"pair_{n:03d}.png")
    for image, path in zip((frames.left, frames.right), paths):
        ok, buf = cv2.imencode(".png", image, PNG_PARAMS)
        if not ok:
            raise RoboCalError("could not encode the camera image as PNG", source=path)
        atomic_write_bytes(path, buf.tobytes())
    return detect_files([paths], board, "cameras", progress=monitor.sub(0.3, 1.0), cancelled=cancelled)


def capture_live_pair(page) -> bool:
    """Start the capture on the Stereo page's job queue (the page's `_need_project`, `_board`,
    `_run_queue`, `_add`, `_adding_finished`)."""
    if not page._need_project():
        return False
    folder = page.state.project.folder / "checkerboard"
    cameras = page.state.cameras
    page._after_adding_note = ""
    page._set_status("Capturing a pair from the cameras…")
    page._run_queue([(partial(capture_checkerboard_pair, cameras, folder, page._board),
                      "Capturing a checkerboard pair", page._add)], then=lambda: page._adding_finished(None))
    return True
