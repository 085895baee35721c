"""The Stereo page's worker functions called directly with plain arguments (no Qt): detect
pairs of image files, choose board poses, render pairs into a folder (and clean up when
cancelled), number the saved pairs."""
from __future__ import annotations

import cv2
import numpy as np
import pytest

from app.jobs.stereo import THUMB_WIDTH, board_poses, detect_files, next_free_number, render_pairs
from core.errors import Cancelled


@pytest.fixture(scope="module")
def lab(built_lab):
    return built_lab(seed=0)


def _paths(folder, n, first=0):
    return [(folder / "left" / f"pair_{first + i:03d}.png", folder / "right" / f"pair_{first + i:03d}.png")
            for i in range(n)]


def test_board_poses_are_reproducible_from_their_seed(lab):
    a = board_poses(lab, 3, [0, 10, 0])
    b = board_poses(lab, 3, [0, 10, 0])
    assert len(a) == 3 and all(np.asarray(p).shape == (4, 4) for p in a)
    for p, q in zip(a, b):
        np.testing.assert_array_equal(p, q)
    assert not np.allclose(a[0], board_poses(lab, 3, [0, 10, 1])[0])


def test_render_pairs_writes_detects_and_reports_progress(lab, tmp_path):
    poses = board_poses(lab, 2, [0, 10, 0])
    seen = []
    added = render_pairs(lab, poses, [[0, 11, 0], [0, 11, 1]], _paths(tmp_path, 2), lab.board,
                         progress=lambda f, m: seen.append(f))
    assert [a.source for a in added] == ["virtual lab", "virtual lab"]
    assert all(a.detection.accepted for a in added)
    assert added[0].thumbnail.ndim == 3 and added[0].thumbnail.shape[1] == 2 * THUMB_WIDTH + 4
    for lp, rp in _paths(tmp_path, 2):
        assert cv2.imread(str(lp), cv2.IMREAD_GRAYSCALE).shape == (lab.rig.left.height, lab.rig.left.width)
        assert rp.is_file()
    assert seen == sorted(seen) and seen[-1] == 1.0
    assert next_free_number(tmp_path) == 2


def test_cancelled_rendering_removes_the_files_it_wrote(lab, tmp_path):
    poses = board_poses(lab, 3, [0, 10, 0])
    calls = []

    def cancelled():
        calls.append(1)
        return len(calls) > 2                    # after the first pair is written

    with pytest.raises(Cancelled):
        render_pairs(lab, poses, [[0, 11, i] for i in range(3)], _paths(tmp_path, 3), lab.board,
                     cancelled=cancelled)
    assert not list((tmp_path / "left").glob("*.png")) and not list((tmp_path / "right").glob("*.png"))


def test_detect_files_keeps_the_source_of_each_pair(lab, tmp_path):
    poses = board_poses(lab, 2, [0, 10, 0])
    render_pairs(lab, poses, [[0, 11, 0], [0, 11, 1]], _paths(tmp_path, 2), lab.board)
    added = detect_files(_paths(tmp_path, 2), lab.board, ["virtual lab", "folders"])
    assert [a.source for a in added] == ["virtual lab", "folders"]
    assert [a.detection.accepted for a in added] == [True, True]
    assert [a.source for a in detect_files(_paths(tmp_path, 1), lab.board)] == ["folders"]
    wrong = detect_files(_paths(tmp_path, 1), type(lab.board)(8, 6, lab.board.square))
    assert not wrong[0].detection.accepted and "8x6" in wrong[0].detection.reason


def test_a_batch_numbers_its_pairs_in_the_whole_list(lab, tmp_path):
    """Pairs 5 and 6 of 20: the messages say so, not "pair 1 of 2"."""
    poses = board_poses(lab, 2, [0, 10, 0])
    said = []
    render_pairs(lab, poses, [[0, 11, 0], [0, 11, 1]], _paths(tmp_path, 2), lab.board, first=4, total=20,
                 progress=lambda f, m: said.append(m))
    assert [m for m in said if m.startswith("rendering")] == ["rendering pair 5 of 20", "rendering pair 6 of 20"]
    assert "detecting the board: pair 6 of 20" in said
    said.clear()
    detect_files(_paths(tmp_path, 2), lab.board, first=18, total=20, progress=lambda f, m: said.append(m))
    assert [m for m in said if m.startswith("detecting")] == ["detecting the board: pair 19 of 20",
                                                              "detecting the board: pair 20 of 20"]


def test_next_free_number_after_the_saved_pairs(tmp_path):
    assert next_free_number(tmp_path) == 0
    (tmp_path / "left").mkdir()
    (tmp_path / "right").mkdir()
    for name in ("pair_000.png", "pair_007.png", "notes.txt"):
        (tmp_path / "left" / name).write_bytes(b"")
    (tmp_path / "right" / "pair_003.png").write_bytes(b"")
    assert next_free_number(tmp_path) == 8
