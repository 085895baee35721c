"""The Stereo page's work, plain Python run on a worker thread (no Qt): detect the board in
pairs of image files, choose board poses in the virtual lab, render pairs into the project
and detect them. Each returns what the page draws; pixels are row-major, lengths in mm."""
from __future__ import annotations

import re
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path
from typing import Sequence

import numpy as np

from core.files import atomic_write_bytes
from core.images import encode_png, load_gray
from core.stereo.board import Board
from core.stereo.screening import detect_pair
from core.stereo.detection import PairDetection
from core.task import Monitor
from core.thumbnails import compose_pair_thumbnail

THUMB_WIDTH = 100           # px per camera in a thumbnail
_PAIR_NAME = re.compile(r"^pair_(\d+)\.png$")


@dataclass
class AddedPair:
    """A pair on the page: its detection (raw verdict, screened again across pairs), the
    thumbnail (row-major RGB), where it came from, and whether the user excluded it."""

    detection: PairDetection
    thumbnail: np.ndarray
    source: str
    key: int = -1
    excluded: bool = False


def thumbnail(left, right, det: PairDetection, board: Board) -> np.ndarray:
    """Left | right of a pair, reduced, with the detected corners drawn."""
    return compose_pair_thumbnail(left, right, det.left.corners, det.right.corners, board.pattern_size,
                                  found=(bool(det.left.ok or det.left.corners is not None),
                                         bool(det.right.ok or det.right.corners is not None)),
                                  width=THUMB_WIDTH)


def detect_files(pairs: Sequence[tuple[Path, Path]], board: Board, sources: str | Sequence[str] = "folders", *,
                 first: int = 0, total: int | None = None, progress=None, cancelled=None) -> list[AddedPair]:
    """Detect the board in image files (two at a time) and make their thumbnails. `sources`:
    where the pairs came from, one for all or one per pair. `first` and `total` number the
    pairs in the progress messages when these are a batch of a longer list."""
    monitor = Monitor(progress, cancelled)
    n = len(pairs)
    total = n if total is None else total
    names = [sources] * n if isinstance(sources, str) else list(sources)

    def work(lr, source):
        left, right = lr
        read = [load_gray(p) for p in (left, right)]
        det = detect_pair(left, right, board, read=read)
        return AddedPair(det, thumbnail(read[0][0], read[1][0], det, board), source)

    out: list[AddedPair] = []
    with ThreadPoolExecutor(max_workers=2) as pool:
        futures = [pool.submit(work, lr, s) for lr, s in zip(pairs, names)]
        try:
            for i, fut in enumerate(futures):
                monitor.step(i / max(n, 1), f"detecting the board: pair {first + i + 1} of {total}")
                out.append(fut.result())
        except BaseException:
            for fut in futures:
                fut.cancel()
            raise
    monitor.step(1.0, "detected")
    return out


def board_poses(lab, count: int, rng_key: Sequence[int], *, progress=None, cancelled=None) -> list[np.ndarray]:
    """`count` well-spread board poses (4x4, mm) in the virtual lab, from the seed `rng_key`."""
    monitor = Monitor(progress, cancelled)
    monitor.step(0.0, "choosing board poses")
    rng = np.random.default_rng(list(rng_key))
    poses = lab.random_board_poses(count, rng, candidates_per_pose=30 if count > 1 else 4)
    monitor.step(1.0, "ready")
    return poses


def render_pairs(lab, poses: Sequence[np.ndarray], seeds: Sequence[Sequence[int]],
                 paths: Sequence[tuple[Path, Path]], board: Board, source: str = "virtual lab", *,
                 first: int = 0, total: int | None = None, progress=None, cancelled=None) -> list[AddedPair]:
    """Render the lab's checkerboard at each pose, save both images as PNG, detect the board
    (overlapping with the next rendering) and make the thumbnails. A cancelled or failed
    run removes the files it wrote. `first` and `total` number the pairs in the progress
    messages when these are a batch of a longer list."""
    monitor = Monitor(progress, cancelled)
    n = len(poses)
    total = n if total is None else total
    written: list[Path] = []
    results = []
    try:
        with ThreadPoolExecutor(max_workers=1) as pool:
            for i, (pose, key, (lp, rp)) in enumerate(zip(poses, seeds, paths)):
                monitor.step(i / max(n, 1), f"rendering pair {first + i + 1} of {total}")
                left, right = lab.render_checkerboard_pair(pose, np.random.default_rng(list(key)))
                for img, p in ((left, lp), (right, rp)):
                    atomic_write_bytes(p, encode_png(img, "a rendered image", p))
                    written.append(Path(p))
                # the images just written (PNG keeps every grey level): detected without reading them back
                results.append((pool.submit(detect_pair, lp, rp, board, read=((left, None), (right, None))), left, right))
            out = []
            for i, (fut, left, right) in enumerate(results):
                monitor.step((i + 0.5) / max(n, 1) * 0.2 + 0.8, f"detecting the board: pair {first + i + 1} of {total}")
                det = fut.result()
                out.append(AddedPair(det, thumbnail(left, right, det, board), source))
    except BaseException:
        for fut, _, _ in results:
            fut.cancel()
        for p in written:
            p.unlink(missing_ok=True)
        raise
    monitor.step(1.0, "rendered")
    return out


def next_free_number(folder: Path) -> int:
    """The first pair number after those already in folder/left and folder/right (pair_NNN.png)."""
    numbers = [-1]
    for side in ("left", "right"):
        d = folder / side
        if d.is_dir():
            for p in d.iterdir():
                m = _PAIR_NAME.match(p.name)
                if m:
                    numbers.append(int(m.group(1)))
    return max(numbers) + 1
