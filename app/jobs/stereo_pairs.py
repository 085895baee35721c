"""The Stereo page's runs that add checkerboard pairs, each ONE worker job (plain Python, no Qt):
detect the board in image-file pairs, or render the virtual lab's pairs into the project and
detect them. A run works in small batches and hands each batch to `shown(pairs)` as soon as it
is done (called on the worker thread: the caller passes it on to the GUI thread), so thumbnails
and coverage fill while the run goes on and a cancelled run keeps the batches it finished.
Progress: every batch (and the choice of board poses) has an equal share of [0, 1]; Cancel is
honoured between and within batches (core.task.Monitor). Each returns the number of pairs it
added; lengths in mm, poses 4x4 in mm."""
from __future__ import annotations

from pathlib import Path
from typing import Callable, Sequence

from app.jobs.stereo import AddedPair, board_poses, detect_files, render_pairs
from core.stereo.board import Board
from core.task import Monitor

RENDER_CHUNK = 4            # pairs rendered per batch
FILE_CHUNK = 6              # pairs detected per batch

#: receives each finished batch of pairs (on the worker thread)
Shown = Callable[[list[AddedPair]], None]


def detect_in_batches(pairs: Sequence[tuple[Path, Path]], board: Board, sources: str | Sequence[str], *,
                      shown: Shown, progress=None, cancelled=None) -> int:
    """Detect `board` in the image files (left, right) FILE_CHUNK pairs at a time; `sources`: where
    the pairs came from, one for all or one per pair. Progress numbers the pairs over all of them."""
    monitor = Monitor(progress, cancelled)
    starts = range(0, len(pairs), FILE_CHUNK)
    for k, s in enumerate(starts):
        batch_sources = sources if isinstance(sources, str) else list(sources[s:s + FILE_CHUNK])
        shown(detect_files(pairs[s:s + FILE_CHUNK], board, batch_sources, first=s, total=len(pairs),
                           progress=monitor.sub(k / len(starts), (k + 1) / len(starts)), cancelled=cancelled))
    monitor.step(1.0, "detected")
    return len(pairs)


def render_virtual_pairs(lab, count: int, folder: Path, board: Board, *, seed: int, first: int,
                         source: str = "virtual lab", shown: Shown, progress=None, cancelled=None) -> int:
    """Choose `count` well-spread board poses in the virtual lab `lab`, render each pair as
    `folder`/left|right/pair_NNN.png (numbered from `first`), detect `board` in them,
    RENDER_CHUNK pairs at a time. The random draws follow `seed` and the pair numbers, so a run
    is repeatable; a cancelled batch leaves no files."""
    monitor = Monitor(progress, cancelled)
    share = 1.0 / (1 + -(-count // RENDER_CHUNK))        # the poses and each batch
    poses = board_poses(lab, int(count), [seed, 10, first], progress=monitor.sub(0.0, share), cancelled=cancelled)
    paths = [(folder / "left" / f"pair_{first + i:03d}.png", folder / "right" / f"pair_{first + i:03d}.png")
             for i in range(len(poses))]
    seeds = [[seed, 11, first + i] for i in range(len(poses))]
    for k, s in enumerate(range(0, len(poses), RENDER_CHUNK)):
        end = s + RENDER_CHUNK
        shown(render_pairs(lab, poses[s:end], seeds[s:end], paths[s:end], board, source, first=s, total=len(poses),
                           progress=monitor.sub(min(1.0, (k + 1) * share), min(1.0, (k + 2) * share)),
                           cancelled=cancelled))
    monitor.step(1.0, "rendered")
    return len(poses)
