"""Checkerboard detection: real pairs, corner order between left and right, acceptance
reasons, image loading that never crashes, coverage and pairing of folders."""
import shutil

import cv2
import numpy as np
import pytest

from core.stereo.board import Board
from core.stereo.screening import detect_folders, detect_pair, detect_pairs, screen_pairs, summarize_rejections
from core.stereo.coverage import Coverage, coverage, param_distance, view_params
from core.stereo.detection import BoardDetectionOptions, board_in_view, detect_corners, grid_deviation
from core.stereo.corner_order import board_symmetries, match_order
from core.stereo.image_files import pair_images
from core.images import decode_gray, load_gray
from core.errors import Cancelled, RoboCalError
from tests.core.stereo_synth import REAL_DATA, real_pairs

BOARD = Board(9, 6, 24.0)

needs_real = pytest.mark.skipif(not REAL_DATA.is_dir(), reason=f"real checkerboard pairs not found at {REAL_DATA}")


def _render(K, R, t, size=(1280, 1024), board=BOARD, px=40, blur=0.8, noise=2.0, seed=0):
    """A board image by warping a texture (inner corner (0,0) of the board at texture px+margin)."""
    nx, ny = board.cols + 1, board.rows + 1
    m = px
    tex = np.full(((ny + 2) * px, (nx + 2) * px), 255, np.uint8)
    for j in range(ny):
        for i in range(nx):
            if (i + j) % 2 == 0:
                tex[m + j * px:m + (j + 1) * px, m + i * px:m + (i + 1) * px] = 0
    s = board.square / px
    S = np.array([[s, 0, -(m + px - 0.5) * s], [0, s, -(m + px - 0.5) * s], [0, 0, 1]])
    H = K @ np.column_stack([R[:, 0], R[:, 1], t]) @ S
    img = cv2.warpPerspective(tex, H, size, flags=cv2.INTER_LINEAR, borderValue=70).astype(np.float32)
    img = cv2.GaussianBlur(img, (0, 0), blur)
    img += np.random.default_rng(seed).normal(0, noise, img.shape)
    corners = (board.object_points().astype(float) @ R.T + t) @ K.T
    return np.clip(img, 0, 255).astype(np.uint8), corners[:, :2] / corners[:, 2:]


K = np.array([[1500.0, 0, 639.5], [0, 1500.0, 511.5], [0, 0, 1]])
R0 = cv2.Rodrigues(np.array([0.25, -0.2, 0.05]))[0]
T0 = np.array([-120.0, -70.0, 900.0])


# ------------------------------------------------------------------ detection


def test_synthetic_board_detected_with_subpixel_accuracy():
    img, truth = _render(K, R0, T0)
    det = detect_corners(img, BOARD)
    assert det.ok and det.image_size == (1280, 1024) and det.method == "sb"
    # the detected order may be any board symmetry: compare as sets
    d = np.linalg.norm(det.corners[:, None] - truth[None], axis=2).min(axis=1)
    assert d.max() < 0.15
    assert det.sharpness_px < 4 and det.square_px > 30


def test_board_in_view_is_a_quick_yes_or_no_for_a_live_preview():
    img, _ = _render(K, R0, T0)
    assert board_in_view(img, BOARD)
    assert board_in_view(cv2.cvtColor(img, cv2.COLOR_GRAY2BGR), BOARD)        # a camera's colour frame
    assert not board_in_view(np.full_like(img, 128), BOARD)                   # no board
    assert not board_in_view(img[:, :700], BOARD)                             # part of it cut off
    assert not board_in_view(img, Board(7, 5, 24.0))                         # another board


def test_a_wrong_corner_from_the_reduced_image_is_not_kept(monkeypatch):
    """SB on the reduced image once returned a corner 6.7 px off; the refinement notices the
    jump and the next detector is used instead of the bad corner."""
    img, truth = _render(K, R0, T0)
    real_sb = cv2.findChessboardCornersSB
    calls = []

    def bad_first(image, pattern, flags=0):
        found, c = real_sb(image, pattern, flags=flags)
        if not calls and found:
            c = c.reshape(-1, 1, 2).copy()
            c[20, 0, 1] += 6.0                      # 12 px at full resolution, > a quarter square
        calls.append(flags)
        return found, c

    monkeypatch.setattr(cv2, "findChessboardCornersSB", bad_first)
    det = detect_corners(img, BOARD)
    assert det.ok and len(calls) >= 1
    d = np.linalg.norm(det.corners[:, None] - truth[None], axis=2).min(axis=1)
    assert d.max() < 0.15


def test_grid_deviation_points_at_a_misplaced_corner():
    _, truth = _render(K, R0, T0)
    assert grid_deviation(truth, BOARD).max() < 0.05          # exact perspective grid
    moved = truth.copy()
    moved[20] += [3.0, -4.0]
    dev = grid_deviation(moved, BOARD)
    assert np.unravel_index(np.argmax(dev), dev.shape) == (2, 2) and dev.max() == pytest.approx(5.0, abs=0.3)


def test_blank_image_not_found_and_wrong_board_size_named():
    det = detect_corners(np.full((512, 640), 120, np.uint8), BOARD)
    assert not det.ok and "board not found" in det.reason
    img, _ = _render(K, R0, T0)
    det = detect_corners(img, Board(8, 6, 24.0))
    assert not det.ok and "9x6" in det.reason and "board size" in det.reason


def test_partial_board_rejected():
    img, truth = _render(K, R0, T0)
    cut = img.copy()
    x = int(np.sort(truth[:, 0])[27])              # hide about half the board
    cut[:, x:] = 70
    det = detect_corners(cut, BOARD)
    assert not det.ok and "partial board" in det.reason


def test_blurred_board_rejected():
    img, _ = _render(K, R0, T0, blur=6.0)
    det = detect_corners(img, BOARD)
    assert not det.ok and det.reason.startswith("blurred")


@needs_real
def test_all_fifty_real_images_detected():
    res = detect_pairs(real_pairs(), BOARD)
    assert res.image_size == (640, 512)
    assert len(res.accepted) == 25, summarize_rejections(res.pairs)
    for p in res.pairs:
        assert p.left.corners.shape == (54, 2) and p.right.corners.shape == (54, 2)
        # same corner order in both images: row and column directions agree
        _, sym, score = match_order(p.left.corners, p.right.corners, BOARD)
        assert sym == "" and score > 1.8
    assert res.coverage.enough and min(res.coverage.bars.values()) >= 0.6


# ------------------------------------------------------------------ corner order


def test_board_symmetries_are_rigid_relabellings():
    for b in (Board(9, 6, 1.0), Board(7, 7, 1.0)):
        obj = b.object_points().astype(float)
        syms = board_symmetries(b.cols, b.rows)
        assert len(syms) == (8 if b.cols == b.rows else 4)
        for name, perm, Rs, ts in syms:
            np.testing.assert_allclose(obj[perm], obj @ Rs.T + ts, atol=1e-9)
            assert np.linalg.det(Rs) == pytest.approx(1.0)


def test_flipped_right_board_is_put_back_in_the_left_order():
    img_l, _ = _render(K, R0, T0)
    img_r, _ = _render(K, R0, T0 + np.array([-130.0, 0, 0]), seed=1)
    pair = detect_pair(img_l, img_r, BOARD)
    assert pair.accepted and pair.reordered == ""
    flipped = pair.right.corners[::-1].copy()          # the detector started at the other end
    fixed, name, score = match_order(pair.left.corners, flipped, BOARD)
    assert name == "rotated 180°" and score > 1.9
    np.testing.assert_array_equal(fixed, pair.right.corners)


def test_board_turned_too_far_between_images_rejected(monkeypatch):
    img, _ = _render(K, R0, T0)
    turned = cv2.rotate(img, cv2.ROTATE_90_CLOCKWISE)
    turned = cv2.resize(turned, (1280, 1024))
    pair = detect_pair(img, turned, BOARD)
    assert not pair.accepted and "turned by more than 60°" in pair.reason


# ------------------------------------------------------------------ acceptance and loading


def test_image_loading_never_crashes(tmp_path):
    img, _ = _render(K, R0, T0, size=(320, 256))
    ok, png = cv2.imencode(".png", img)
    ok, jpg = cv2.imencode(".jpg", img)
    (tmp_path / "good.png").write_bytes(png.tobytes())
    (tmp_path / "trunc.png").write_bytes(png.tobytes()[: len(png) // 2])
    (tmp_path / "trunc.jpg").write_bytes(jpg.tobytes()[: len(jpg) // 2])
    (tmp_path / "garbage.png").write_bytes(b"this is not an image at all" * 10)
    (tmp_path / "empty.jpg").write_bytes(b"")
    (tmp_path / "folder.png").mkdir()
    assert load_gray(tmp_path / "good.png")[0].shape == (256, 320)
    reasons = {name: load_gray(tmp_path / name)[1] for name in
               ("trunc.png", "trunc.jpg", "garbage.png", "empty.jpg", "folder.png", "missing.png")}
    assert "truncated PNG" in reasons["trunc.png"]
    assert "truncated JPEG" in reasons["trunc.jpg"]
    assert reasons["garbage.png"] == "not a readable image"
    assert reasons["empty.jpg"] == "empty file"
    assert "folder" in reasons["folder.png"]
    assert reasons["missing.png"] == "file not found"
    colour16 = cv2.cvtColor(img, cv2.COLOR_GRAY2BGR).astype(np.uint16) * 257
    ok, buf = cv2.imencode(".png", colour16)
    gray, why = decode_gray(buf.tobytes())
    assert why is None and gray.dtype == np.uint8 and np.abs(gray.astype(int) - img).max() <= 1


def test_pair_reasons_size_mismatch_unreadable_and_similar(tmp_path):
    img_l, _ = _render(K, R0, T0)
    img_r, _ = _render(K, R0, T0 + np.array([-130.0, 0, 0]), seed=1)
    small = cv2.resize(img_r, (640, 512))
    p = detect_pair(img_l, small, BOARD)
    assert not p.accepted and "size mismatch" in p.reason
    (tmp_path / "bad.png").write_bytes(b"garbage")
    p = detect_pair(tmp_path / "bad.png", img_r, BOARD)
    assert not p.accepted and "bad.png: not a readable image" in p.reason
    res = detect_pairs([(img_l, img_r), (img_l, img_r)], BOARD)
    assert res.pairs[0].accepted and not res.pairs[1].accepted
    assert "too similar to pair 1" in res.pairs[1].reason
    line = summarize_rejections(res.pairs)
    assert "too similar" in line


def test_screen_pairs_again_after_removing_one():
    """A page adds and removes pairs: the checks across pairs start again from each pair's
    own verdict."""
    img_l, _ = _render(K, R0, T0)
    img_r, _ = _render(K, R0, T0 + np.array([-130.0, 0, 0]), seed=1)
    first = detect_pair(img_l, img_r, BOARD)
    second = detect_pair(img_l, img_r, BOARD)
    res = screen_pairs([first, second], BOARD)
    assert [p.accepted for p in res.pairs] == [True, False] and res.coverage.pairs == 1
    res = screen_pairs([second], BOARD)
    assert res.pairs[0].accepted and res.pairs[0].index == 0 and res.pairs[0].reason is None


def test_pairs_with_a_different_image_size_rejected():
    a, _ = _render(K, R0, T0)
    b, _ = _render(K, R0, T0 + np.array([-130.0, 0, 0]), seed=1)
    c, _ = _render(K, R0, T0 + np.array([60.0, 40, 100]), size=(1200, 1000))
    d, _ = _render(K, R0, T0 + np.array([-70.0, 40, 100]), size=(1200, 1000))
    e, _ = _render(K, cv2.Rodrigues(np.array([-0.3, 0.3, 0.0]))[0], T0 + np.array([100.0, 80, 0]))
    f, _ = _render(K, cv2.Rodrigues(np.array([-0.3, 0.3, 0.0]))[0], T0 + np.array([-30.0, 80, 0]))
    res = detect_pairs([(a, b), (c, d), (e, f)], BOARD, BoardDetectionOptions(workers=1))
    assert res.image_size == (1280, 1024)
    assert [p.accepted for p in res.pairs] == [True, False, True]
    assert "differs from the other pairs' 1280x1024" in res.pairs[1].reason


def test_detect_pairs_progress_and_cancel():
    img, _ = _render(K, R0, T0, size=(320, 256))
    seen = []
    detect_pairs([(img, img)] * 3, BOARD, BoardDetectionOptions(workers=1), progress=lambda f, m: seen.append(f))
    assert seen[-1] == 1.0
    with pytest.raises(Cancelled):
        detect_pairs([(img, img)] * 3, BOARD, cancelled=lambda: True)


# ------------------------------------------------------------------ view parameters and coverage


def test_view_params_of_a_frontal_centred_board():
    b = Board(9, 6, 1.0)
    grid = b.object_points()[:, :2].astype(float) * 40 + [160, 150]      # 320 x 200 px board
    p = view_params(grid, b, (640, 500))
    assert p[0] == pytest.approx(0.5, abs=1e-6) and p[1] == pytest.approx(0.5, abs=1e-6)
    assert p[2] == pytest.approx(np.sqrt(320 * 200 / (640 * 500)))
    assert p[3] == pytest.approx(0.0, abs=1e-9)
    assert param_distance(p, p + [0.1, 0, 0, 0.05]) == pytest.approx(0.15)


def test_coverage_bars_and_enough_rule():
    from core.stereo.detection import Detection, PairDetection

    def pair(i, params):
        p = PairDetection(i, f"p{i}", "l", "r", Detection(True), Detection(True), accepted=True)
        p.params_left = p.params_right = np.array(params, dtype=float)
        return p

    few = [pair(0, [0.5, 0.5, 0.2, 0.1])]
    cov = coverage(few)
    assert cov.x == 0 and cov.size == pytest.approx(0.5) and cov.skew == pytest.approx(0.2)
    assert not cov.enough and any("add pairs" in a for a in cov.advice)
    spread = [pair(i, [x, y, 0.3, 0.4]) for i, (x, y) in
              enumerate([(0.1, 0.1), (0.9, 0.1), (0.1, 0.9), (0.9, 0.9), (0.5, 0.5)] * 2)]
    cov = coverage(spread)
    assert cov.bars == {"X": 1.0, "Y": 1.0, "size": pytest.approx(0.75), "skew": pytest.approx(0.8)}
    assert cov.enough and cov.pairs == 10
    narrow = [pair(i, [0.5 + 0.01 * i, 0.5, 0.3, 0.4]) for i in range(12)]
    cov = coverage(narrow)
    assert not cov.enough and any(a.startswith("X coverage") for a in cov.advice)
    assert isinstance(Coverage().to_dict(), dict)


# ------------------------------------------------------------------ folders


def test_pair_images_by_sorted_name_and_unequal_counts(tmp_path):
    left, right = tmp_path / "L", tmp_path / "R"
    left.mkdir()
    right.mkdir()
    for n in (2, 1, 3):
        (left / f"l{n}.png").write_bytes(b"x")
        (right / f"r{n}.png").write_bytes(b"x")
    (left / "notes.txt").write_text("hello")
    (left / ".hidden.png").write_bytes(b"x")
    pairs, ignored = pair_images(left, right)
    assert [(a.name, b.name) for a, b in pairs] == [("l1.png", "r1.png"), ("l2.png", "r2.png"), ("l3.png", "r3.png")]
    assert ignored == [f"{left}: notes.txt"]
    (right / "r4.png").write_bytes(b"x")
    with pytest.raises(RoboCalError, match="3 left images .* 4 right images.*r4.png"):
        pair_images(left, right)
    with pytest.raises(RoboCalError, match="same folder"):
        pair_images(left, left)
    with pytest.raises(RoboCalError, match="no such folder"):
        pair_images(tmp_path / "nope", right)
    pairs, _ = pair_images(str(left / "l*.png"), [right / "r1.png", right / "r2.png", right / "r3.png"])
    assert len(pairs) == 3


@needs_real
def test_detect_folders_on_copied_real_pairs(tmp_path):
    left, right = tmp_path / "left", tmp_path / "right"
    left.mkdir()
    right.mkdir()
    for a, b in real_pairs([1, 2]):
        shutil.copy(a, left / a.name)
        shutil.copy(b, right / b.name)
    res = detect_folders(left, right, BOARD)
    assert [p.accepted for p in res.pairs] == [True, True]
    assert res.pairs[0].name == "left01.jpg | right01.jpg"
