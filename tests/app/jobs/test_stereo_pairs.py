"""The Stereo page's adding runs, each one worker job, called directly with plain arguments (no
Qt): batches handed over as they finish, one progress over all of them, Cancel keeping the
finished batches (and no files of the cancelled one), repeatable renderings."""
from __future__ import annotations

import cv2
import numpy as np
import pytest

from app.jobs import stereo_pairs
from app.jobs.stereo_pairs import FILE_CHUNK, detect_in_batches, render_virtual_pairs
from core.errors import Cancelled


@pytest.fixture(scope="module")
def lab(built_lab):
    return built_lab(seed=0)


@pytest.fixture(scope="module")
def image_pairs(lab, tmp_path_factory):
    """FILE_CHUNK + 2 rendered pairs as PNG files (left, right)."""
    root = tmp_path_factory.mktemp("pairs")
    poses = lab.random_board_poses(FILE_CHUNK + 2, np.random.default_rng(3))
    pairs = []
    for i, pose in enumerate(poses):
        left, right = lab.render_checkerboard_pair(pose, np.random.default_rng([3, i]))
        paths = (root / f"l{i:02d}.png", root / f"r{i:02d}.png")
        for image, path in zip((left, right), paths):
            assert cv2.imwrite(str(path), image)
        pairs.append(paths)
    return pairs


def test_detection_hands_over_each_batch_with_one_progress(lab, image_pairs):
    batches, seen = [], []
    sources = [f"source {i}" for i in range(len(image_pairs))]
    n = detect_in_batches(image_pairs, lab.board, sources, shown=batches.append,
                          progress=lambda f, m: seen.append((f, m)))
    assert n == len(image_pairs) and [len(b) for b in batches] == [FILE_CHUNK, 2]
    added = [a for b in batches for a in b]
    assert [a.source for a in added] == sources
    assert [a.detection.name for a in added] == [f"l{i:02d}.png | r{i:02d}.png" for i in range(len(image_pairs))]
    assert all(a.detection.accepted for a in added)
    fractions = [f for f, _ in seen]
    assert fractions == sorted(fractions) and fractions[-1] == 1.0
    # the second batch numbers its pairs after the first, over all of them
    assert f"pair {FILE_CHUNK + 1} of {len(image_pairs)}" in " ".join(m for _, m in seen)


def test_cancel_keeps_the_finished_batches(lab, image_pairs):
    batches = []
    with pytest.raises(Cancelled):
        detect_in_batches(image_pairs, lab.board, "folders", shown=batches.append, cancelled=lambda: bool(batches))
    assert [len(b) for b in batches] == [FILE_CHUNK]


@pytest.mark.no_session_cache
def test_virtual_pairs_are_rendered_in_batches_and_repeatable(lab, tmp_path, monkeypatch):
    monkeypatch.setattr(stereo_pairs, "RENDER_CHUNK", 2)
    batches, seen = [], []
    n = render_virtual_pairs(lab, 3, tmp_path / "a", lab.board, seed=7, first=4, shown=batches.append,
                             progress=lambda f, m: seen.append(f))
    assert n == 3 and [len(b) for b in batches] == [2, 1]
    assert sorted(p.name for p in (tmp_path / "a" / "left").iterdir()) == ["pair_004.png", "pair_005.png",
                                                                            "pair_006.png"]
    assert all(a.source == "virtual lab" and a.detection.accepted for b in batches for a in b)
    assert seen == sorted(seen) and seen[-1] == 1.0
    again = []
    render_virtual_pairs(lab, 3, tmp_path / "b", lab.board, seed=7, first=4, shown=again.append)
    for side in ("left", "right"):
        for name in ("pair_004.png", "pair_006.png"):
            assert (tmp_path / "a" / side / name).read_bytes() == (tmp_path / "b" / side / name).read_bytes()


def test_cancelled_rendering_keeps_finished_batches_and_their_files_only(lab, tmp_path, monkeypatch):
    monkeypatch.setattr(stereo_pairs, "RENDER_CHUNK", 1)
    batches = []
    with pytest.raises(Cancelled):
        render_virtual_pairs(lab, 3, tmp_path, lab.board, seed=7, first=0, shown=batches.append,
                             cancelled=lambda: len(batches) >= 2)
    assert [len(b) for b in batches] == [1, 1]
    for side in ("left", "right"):
        assert sorted(p.name for p in (tmp_path / side).iterdir()) == ["pair_000.png", "pair_001.png"]
