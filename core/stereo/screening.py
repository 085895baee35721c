"""Checkerboard pairs for stereo calibration screened: each pair detected and accepted or
rejected with a reason (`detect_pair`), then the checks across pairs (`screen_pairs`), for a
batch of pairs (`detect_pairs`) or two folders (`detect_folders`, the files paired by
core.stereo.image_files), and the rejections summarised in one line.

Acceptance of a pair, in this order: both images readable, same size, board found in both, not
at the border, not blurred, corner order consistent between the two images; across pairs: the
most frequent image size, and not too similar to an earlier accepted pair.

Detection of one image: core.stereo.detection.
Corner order: core.stereo.corner_order; a pair whose row and column directions disagree between
the two images by more than 60° is rejected with a reason.

Coverage of the accepted views and the "enough views" rule: core.stereo.coverage.

Similar views: ROS drops a live frame whose parameters are within L1 distance 0.2 of an
accepted one; for files the user chose, `min_param_distance` defaults to 0.05 (only
near-duplicates, which add weight but no information; on the real data set the closest two
pairs are 0.16 apart, and 0.2 would drop 4 of 25 good pairs).
"""
from __future__ import annotations

import os
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path
from typing import Sequence

from core.images import load_gray, to_gray8
from core.stereo.board import Board
from core.stereo.corner_order import match_order
from core.stereo.coverage import Coverage, coverage, param_distance, view_params
from core.stereo.detection import BoardDetectionOptions, Detection, PairDetection, detect_corners
from core.stereo.image_files import pair_images
from core.task import Monitor


@dataclass
class DetectionResult:
    """All pairs of a data set, in file order, with the accepted ones and the coverage."""

    board: Board
    pairs: list[PairDetection]
    image_size: tuple[int, int] | None
    coverage: Coverage
    ignored_files: list[str] = field(default_factory=list)   # non-image files in the folders

    @property
    def accepted(self) -> list[PairDetection]:
        return [p for p in self.pairs if p.accepted]

    @property
    def rejected(self) -> list[PairDetection]:
        return [p for p in self.pairs if not p.accepted]


# --------------------------------------------------------------------------- pairs


def detect_pair(left, right, board: Board, options: BoardDetectionOptions = BoardDetectionOptions(), *,
                index: int = 0, name: str | None = None, read=None) -> PairDetection:
    """Detect and check one pair. `left`/`right` are image paths or arrays; `read`, if given, is
    what `load_gray` gave for the two paths (gray image or None, why), read once by the caller.

    Acceptance (in this order): both images readable, same size, board found in both,
    not at the border, not blurred, corner order consistent between the two images.
    (Similarity to other pairs and the common image size are checked by `detect_pairs`.)
    """
    lp = str(left) if isinstance(left, (str, Path)) else "left"
    rp = str(right) if isinstance(right, (str, Path)) else "right"
    if name is None:
        name = f"{Path(lp).name} | {Path(rp).name}"
    dets = []
    for k, src in enumerate((left, right)):
        if read is not None:
            gray, why = read[k]
        elif isinstance(src, (str, Path)):
            gray, why = load_gray(src)
        else:
            gray, why = (to_gray8(src), None) if src is not None else (None, "no image")
        if gray is None:
            dets.append(Detection(False, None, None, why))
        else:
            dets.append(detect_corners(gray, board, options))
    dl, dr = dets
    pair = PairDetection(index, name, lp, rp, dl, dr)
    ln, rn = Path(lp).name, Path(rp).name
    if dl.image_size is None or dr.image_size is None:
        bad = [f"{n}: {d.reason}" for n, d in ((ln, dl), (rn, dr)) if d.image_size is None]
        pair.reason = "; ".join(bad)
        return _verdict(pair)
    if dl.image_size != dr.image_size:
        pair.reason = (f"left/right image size mismatch: {ln} is {dl.image_size[0]}x{dl.image_size[1]}, "
                       f"{rn} is {dr.image_size[0]}x{dr.image_size[1]}")
        return _verdict(pair)
    if not dl.ok or not dr.ok:
        bad = [f"{n}: {d.reason}" for n, d in ((ln, dl), (rn, dr)) if not d.ok]
        pair.reason = "; ".join(bad)
        return _verdict(pair)
    fixed, sym, score = match_order(dl.corners, dr.corners, board)
    if score < 1.0:
        pair.reason = ("the board appears turned by more than 60° between the left and right images; "
                       "cannot match the corners")
        return _verdict(pair)
    dr.corners, pair.reordered = fixed, sym
    pair.params_left = view_params(dl.corners, board, dl.image_size)
    pair.params_right = view_params(dr.corners, board, dr.image_size)
    pair.accepted = True
    return _verdict(pair)


def _verdict(pair: PairDetection) -> PairDetection:
    pair.detected_ok, pair.detected_reason = pair.accepted, pair.reason
    return pair


def detect_pairs(pairs: Sequence[tuple], board: Board, options: BoardDetectionOptions = BoardDetectionOptions(), *,
                 names: Sequence[str] | None = None, ignored_files: Sequence[str] = (),
                 progress=None, cancelled=None) -> DetectionResult:
    """Detect every pair (paths or arrays), then check sizes and similarity across pairs.

    Pairs are processed in order; a pair too similar to an earlier accepted one is
    rejected. The common image size is the most frequent size among readable pairs.
    """
    monitor = Monitor(progress, cancelled)
    n = len(pairs)
    monitor.step(0.0, f"detecting the board in {n} pairs")
    results: list[PairDetection | None] = [None] * n

    def work(i):
        left, right = pairs[i]
        name = names[i] if names is not None else None
        return detect_pair(left, right, board, options, index=i, name=name)

    workers = max(1, min(int(options.workers), n, os.cpu_count() or 1))
    if workers == 1:
        for i in range(n):
            monitor.check()
            results[i] = work(i)
            monitor.step((i + 1) / max(n, 1), f"pair {i + 1} of {n}")
    else:
        with ThreadPoolExecutor(max_workers=workers) as pool:
            futures = [pool.submit(work, i) for i in range(n)]
            try:
                for i, fut in enumerate(futures):
                    results[i] = fut.result()
                    monitor.step((i + 1) / max(n, 1), f"pair {i + 1} of {n}")
            except BaseException:
                for fut in futures:
                    fut.cancel()
                raise
    return screen_pairs([p for p in results if p is not None], board, options, ignored_files=ignored_files)


def screen_pairs(pairs: Sequence[PairDetection], board: Board, options: BoardDetectionOptions = BoardDetectionOptions(),
                 *, ignored_files: Sequence[str] = ()) -> DetectionResult:
    """The checks across pairs, redone from each pair's own verdict (`detect_pair`).

    For a page that adds or removes pairs one at a time: pairs are renumbered in list
    order, the common image size is the most frequent one, and a pair too similar to an
    earlier accepted one is rejected. Returns the DetectionResult with its coverage.
    """
    found = list(pairs)
    for i, p in enumerate(found):
        p.index = i
        p.accepted, p.reason = p.detected_ok, p.detected_reason
    sizes = [p.left.image_size for p in found
             if p.left.image_size is not None and p.left.image_size == p.right.image_size]
    image_size = max(set(sizes), key=lambda s: (sizes.count(s), -sizes.index(s))) if sizes else None
    kept: list[PairDetection] = []
    for p in found:
        if not p.accepted:
            continue
        if p.image_size != image_size:
            p.accepted = False
            p.reason = (f"image size {p.image_size[0]}x{p.image_size[1]} differs from the other pairs' "
                        f"{image_size[0]}x{image_size[1]}")
            continue
        for q in kept:
            d = max(param_distance(p.params_left, q.params_left), param_distance(p.params_right, q.params_right))
            if d <= options.min_param_distance:
                p.accepted = False
                p.reason = (f"too similar to pair {q.index + 1} ({q.name}): view distance {d:.3f} "
                            f"<= {options.min_param_distance}")
                break
        if p.accepted:
            kept.append(p)
    return DetectionResult(board, found, image_size, coverage(found), list(ignored_files))


def detect_folders(left, right, board: Board, options: BoardDetectionOptions = BoardDetectionOptions(), *,
                   progress=None, cancelled=None) -> DetectionResult:
    """Pair the images of two folders (or patterns, or file lists) by sorted name and detect."""
    pairs, ignored = pair_images(left, right)
    return detect_pairs(pairs, board, options, ignored_files=ignored, progress=progress, cancelled=cancelled)


def summarize_rejections(pairs: Sequence[PairDetection], limit: int = 6) -> str:
    """One line grouping the rejected pairs' problems: 'reason [files]; reason [files]'.

    Problems of single images (unreadable, board not found, blurred, ...) are grouped by
    reason with the image names; problems of a pair (size mismatch, too similar, ...) with
    the pair names.
    """
    groups: dict[str, list[str]] = {}
    for p in pairs:
        if p.accepted:
            continue
        image_level = False
        for det, path in ((p.left, p.left_path), (p.right, p.right_path)):
            if not det.ok and det.reason:
                groups.setdefault(det.reason, []).append(Path(path).name)
                image_level = True
        if not image_level:
            groups.setdefault(p.reason or "rejected", []).append(p.name)
    parts = []
    for reason, names in groups.items():
        shown = ", ".join(names[:limit]) + (f", ... ({len(names)} in all)" if len(names) > limit else "")
        parts.append(f"{reason} [{shown}]")
    return "; ".join(parts)
