"""The Stereo page's Capture from cameras with the cameras opened on the Setup page (image
folders as the cameras: rendered checkerboard pairs, and frames of the arm without a board):
the live view says for each camera whether it sees the board, a capture is allowed only while
both do; each pair is saved numbered into the project's checkerboard folders and detected, the
coverage bars follow, and the calibration can be made from them."""
from __future__ import annotations

import cv2
import numpy as np
import pytest
from PySide6.QtCore import Qt

from app.hardware import CameraChoice, LiveCameras
from app.pages.stereo.live_preview import NOT_SEEN, SEEN
from app.pages.stereo.page import StereoPage
from app.state import WizardState
from app.worker import TaskRunner
from core.project import HARDWARE
from core.stereo.checkerboard import coverage
from core.virtual_lab.lab import VirtualLab

N_PAIRS = 8


@pytest.fixture(scope="module")
def camera_folders(tmp_path_factory):
    lab = VirtualLab.create(seed=0)
    root = tmp_path_factory.mktemp("cams")
    for side in ("left", "right"):
        (root / side).mkdir()
    for i, pose in enumerate(lab.random_board_poses(N_PAIRS, np.random.default_rng(8))):
        left, right = lab.render_checkerboard_pair(pose, np.random.default_rng([8, i]))
        cv2.imwrite(str(root / "left" / f"frame_{i:02d}.png"), left)
        cv2.imwrite(str(root / "right" / f"frame_{i:02d}.png"), right)
    return root


@pytest.fixture(scope="module")
def no_board_folder(tmp_path_factory):
    """Frames of the arm carrying its marker, no checkerboard anywhere."""
    lab = VirtualLab.create(seed=0)
    root = tmp_path_factory.mktemp("noboard")
    (root / "left").mkdir()
    (root / "right").mkdir()
    rng = np.random.default_rng(5)
    for i, q in enumerate(lab.random_visible_poses(3, rng)):
        left, right = lab.render_marker_pair(q, np.random.default_rng([5, i]))
        cv2.imwrite(str(root / "left" / f"frame_{i:02d}.png"), left)
        cv2.imwrite(str(root / "right" / f"frame_{i:02d}.png"), right)
    return root


def open_cameras(page, left, right) -> None:
    page.state.set_cameras(LiveCameras.open(CameraChoice("sources", str(left), str(right))))


def wait_for_check(page, qtbot, seen) -> None:
    """Until the live view has shown a few pairs and says `seen` (left, right)."""
    pump = page.live.pump
    assert pump is not None and pump.running
    qtbot.waitUntil(lambda: pump.shown >= 3 and page.live.seen == seen, timeout=20000)


@pytest.fixture
def page(qtbot, tmp_path):
    state, tasks = WizardState(), TaskRunner()
    state.new_project(tmp_path / "project", mode=HARDWARE)
    p = StereoPage(state, tasks)
    qtbot.addWidget(p)
    p.resize(1100, 900)
    p.show()
    yield p
    tasks.shutdown()
    state.close()


def test_capture_pairs_from_the_cameras_into_the_project(page, qtbot, camera_folders):
    button = page.pairs.capture_button
    assert not button.isEnabled() and not page.live.isVisible()
    open_cameras(page, camera_folders / "left", camera_folders / "right")
    assert page.live.isVisible()
    wait_for_check(page, qtbot, (True, True))
    assert button.isEnabled() and "hold the board still" in button.toolTip()
    for _ in range(N_PAIRS):
        qtbot.waitUntil(button.isEnabled, timeout=20000)
        qtbot.mouseClick(button, Qt.MouseButton.LeftButton)
        qtbot.waitUntil(lambda: not page.busy, timeout=30000)
    folder = page.state.project.folder / "checkerboard"
    for side in ("left", "right"):
        assert sorted(p.name for p in (folder / side).iterdir()) == [f"pair_{i:03d}.png" for i in range(N_PAIRS)]
    # the preview reads the same folders between captures: each pair is one frame of both cameras
    frames = {i: [cv2.imread(str(camera_folders / side / f"frame_{i:02d}.png"), cv2.IMREAD_UNCHANGED)
                  for side in ("left", "right")] for i in range(N_PAIRS)}
    for n in range(N_PAIRS):
        pair = [cv2.imread(str(folder / side / f"pair_{n:03d}.png"), cv2.IMREAD_UNCHANGED) for side in ("left", "right")]
        assert any(all(np.array_equal(a, b) for a, b in zip(pair, f)) for f in frames.values()), n
    assert len(page.items) == N_PAIRS and {a.source for a in page.items} == {"cameras"}
    assert sum(a.detection.detected_ok for a in page.items) >= N_PAIRS - 1
    assert page.calibrate()
    qtbot.waitUntil(lambda: not page.busy, timeout=90000)
    assert page.result is not None and page.result.file.rms_stereo < 1.0


def test_no_board_in_view_no_capture(page, qtbot, no_board_folder):
    button = page.pairs.capture_button
    open_cameras(page, no_board_folder / "left", no_board_folder / "right")
    wait_for_check(page, qtbot, (False, False))
    assert page.live.left_label.text() == NOT_SEEN and page.live.right_label.text() == NOT_SEEN
    assert not button.isEnabled() and "both cameras" in button.toolTip()
    assert not page.capture_pair()
    assert not page.busy and page.items == []
    assert not (page.state.project.folder / "checkerboard" / "left").exists()


def test_board_in_one_camera_only_no_capture(page, qtbot, camera_folders, no_board_folder):
    open_cameras(page, camera_folders / "left", no_board_folder / "right")
    wait_for_check(page, qtbot, (True, False))
    assert page.live.left_label.text() == SEEN and page.live.right_label.text() == NOT_SEEN
    assert not page.pairs.capture_button.isEnabled()
    assert not page.capture_pair() and page.items == []


def test_board_comes_into_view_capture_adds_pairs_and_coverage(page, qtbot, camera_folders, no_board_folder):
    button, bars = page.pairs.capture_button, page.pairs.coverage_bars
    open_cameras(page, no_board_folder / "left", no_board_folder / "right")
    wait_for_check(page, qtbot, (False, False))
    assert not button.isEnabled()
    open_cameras(page, camera_folders / "left", camera_folders / "right")
    wait_for_check(page, qtbot, (True, True))
    assert page.live.left_label.text() == SEEN and page.live.right_label.text() == SEEN
    assert button.isEnabled()
    assert all(v == 0.0 for v in bars.values().values())
    for n in (1, 2, 3):
        qtbot.waitUntil(button.isEnabled, timeout=20000)
        qtbot.mouseClick(button, Qt.MouseButton.LeftButton)
        qtbot.waitUntil(lambda: not page.busy and len(page.items) == n, timeout=30000)
    assert all(a.detection.accepted for a in page.items)
    expected = coverage([a.detection for a in page.items]).bars
    assert bars.values() == pytest.approx(expected) and min(expected.values()) > 0.0
    assert page.pairs.count_label.text().startswith("<b>3 pairs</b>")


def test_preview_stops_when_hidden_and_with_the_cameras(page, qtbot, camera_folders):
    open_cameras(page, camera_folders / "left", camera_folders / "right")
    wait_for_check(page, qtbot, (True, True))
    page.hide()
    assert page.live.pump is None and page.live.seen is None and not page.pairs.capture_button.isEnabled()
    page.show()
    wait_for_check(page, qtbot, (True, True))
    page.state.set_cameras(None)
    assert page.live.pump is None and not page.live.isVisible()
