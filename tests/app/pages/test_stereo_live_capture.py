"""The Stereo page's Capture from cameras with the cameras opened on the Setup page (image
folders as the cameras: rendered checkerboard pairs and a blank frame): the live view checks
every pair for the board on its worker, a capture is allowed only while the pair shown has the
board in both images, and the capture saves that very pair (what you see is what you save);
the coverage bars follow, and a full live capture calibrates.

No waiting on time: every wait is on the page's own state (qtbot.waitUntil)."""
from __future__ import annotations

import threading

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
from core.stereo.coverage import coverage

N_PAIRS = 8
WAIT_MS = 30000


def write_pair(root, name: str, left: np.ndarray, right: np.ndarray) -> None:
    for side, image in (("left", left), ("right", right)):
        (root / side).mkdir(exist_ok=True)
        assert cv2.imwrite(str(root / side / f"{name}.png"), image)


@pytest.fixture(scope="module")
def rendered(built_lab):
    """N_PAIRS rendered checkerboard pairs (left, right) at well-spread board poses."""
    lab = built_lab(seed=0)
    poses = lab.random_board_poses(N_PAIRS, np.random.default_rng(8))
    return [lab.render_checkerboard_pair(pose, np.random.default_rng([8, i])) for i, pose in enumerate(poses)]


@pytest.fixture(scope="module")
def camera_folders(tmp_path_factory, rendered):
    """The rendered pairs as frame_00 … frame_07 and a blank frame_08 (no board) in both folders."""
    root = tmp_path_factory.mktemp("cams")
    for i, (left, right) in enumerate(rendered):
        write_pair(root, f"frame_{i:02d}", left, right)
    write_pair(root, f"frame_{N_PAIRS:02d}", np.full_like(rendered[0][0], 128), np.full_like(rendered[0][1], 128))
    return root


@pytest.fixture(scope="module")
def one_sided_folders(tmp_path_factory, rendered):
    """The board in the left camera only (the right one shows a blank image)."""
    root = tmp_path_factory.mktemp("onesided")
    left, right = rendered[0]
    write_pair(root, "frame_00", left, np.full_like(right, 128))
    return root


def frame_index(pair, rendered) -> int | None:
    """Which rendered pair `pair` (a PreviewPair) is, byte for byte, in both cameras; None: none."""
    for i, (left, right) in enumerate(rendered):
        if same(pair.left, left) and same(pair.right, right):
            return i
    return None


def same(a: np.ndarray, b: np.ndarray) -> bool:
    return a.dtype == b.dtype and a.shape == b.shape and a.tobytes() == b.tobytes()


def open_cameras(page, folders) -> None:
    page.state.hardware.set_cameras(LiveCameras.open(CameraChoice("sources", str(folders / "left"), str(folders / "right"))))


def saved_pair(page, n: int) -> list[np.ndarray]:
    folder = page.state.project.folder / "checkerboard"
    return [cv2.imread(str(folder / side / f"pair_{n:03d}.png"), cv2.IMREAD_UNCHANGED) for side in ("left", "right")]


def preview_threads() -> list[threading.Thread]:
    return [t for t in threading.enumerate() if t.name == "camera-preview"]


@pytest.fixture
def page(qtbot, tmp_path):
    state, tasks = WizardState(), TaskRunner()
    state.new_project(tmp_path / "project", mode=HARDWARE)
    p = StereoPage(state, tasks)
    qtbot.addWidget(p)
    p.resize(1100, 900)
    p.show()
    yield p
    p.close()                      # hidden: the preview's worker stops
    tasks.shutdown()
    state.close()
    assert p.live.pump is None and preview_threads() == []


def test_capture_only_while_the_pair_shown_has_the_board_in_both(page, qtbot, camera_folders):
    button, live = page.pairs.capture_button, page.live
    assert not button.isEnabled() and not live.isVisible()
    open_cameras(page, camera_folders)
    assert live.isVisible() and live.pump is not None and live.pump.running
    # the blank frame is the one shown: no capture
    qtbot.waitUntil(lambda: live.seen == (False, False), timeout=WAIT_MS)
    assert live.left_label.text() == NOT_SEEN and live.right_label.text() == NOT_SEEN
    assert live.ready_pair() is None and not button.isEnabled() and "both cameras" in button.toolTip()
    assert not page.sources.capture_pair() and not page.task.busy and page.items == []
    assert not (page.state.project.folder / "checkerboard" / "left").exists()
    # a board frame is the one shown: Capture is allowed
    qtbot.waitUntil(lambda: live.seen == (True, True), timeout=WAIT_MS)
    assert live.left_label.text() == SEEN and live.right_label.text() == SEEN
    assert live.ready_pair() is live.pump.latest
    assert button.isEnabled() and "hold the board still" in button.toolTip()


def test_board_in_one_camera_only_no_capture(page, qtbot, one_sided_folders):
    open_cameras(page, one_sided_folders)
    qtbot.waitUntil(lambda: page.live.seen == (True, False), timeout=WAIT_MS)
    assert page.live.left_label.text() == SEEN and page.live.right_label.text() == NOT_SEEN
    assert not page.pairs.capture_button.isEnabled()
    assert not page.sources.capture_pair() and page.items == []


def test_the_pair_saved_is_the_pair_checked(page, qtbot, camera_folders, rendered):
    open_cameras(page, camera_folders)
    live = page.live
    qtbot.waitUntil(lambda: live.ready_pair() is not None, timeout=WAIT_MS)
    pair = live.ready_pair()
    assert pair.answer == (True, True) and frame_index(pair, rendered) is not None
    assert page.sources.capture_pair()
    assert live.ready_pair() is None              # this pair cannot be saved twice
    qtbot.waitUntil(lambda: not page.task.busy and len(page.items) == 1, timeout=WAIT_MS)
    left, right = saved_pair(page, 0)
    assert same(left, pair.left) and same(right, pair.right)
    assert page.items[0].source == "cameras" and page.items[0].detection.accepted


def test_live_capture_of_every_frame_calibrates(page, qtbot, camera_folders, rendered):
    button, bars, live = page.pairs.capture_button, page.pairs.coverage_bars, page.live
    open_cameras(page, camera_folders)
    assert all(v == 0.0 for v in bars.values().values())
    taken: list[int] = []

    def new_frame_ready() -> bool:
        pair = live.ready_pair()
        return pair is not None and frame_index(pair, rendered) not in taken and button.isEnabled()

    for n in range(N_PAIRS):
        qtbot.waitUntil(new_frame_ready, timeout=WAIT_MS)
        pair = live.ready_pair()
        qtbot.mouseClick(button, Qt.MouseButton.LeftButton)
        assert page.task.busy and live.ready_pair() is None     # the click took the pair shown
        taken.append(frame_index(pair, rendered))
        qtbot.waitUntil(lambda: not page.task.busy and len(page.items) == n + 1, timeout=WAIT_MS)
        assert all(same(a, b) for a, b in zip(saved_pair(page, n), (pair.left, pair.right)))
        expected = coverage([a.detection for a in page.usable_pairs()]).bars
        assert bars.values() == pytest.approx(expected)   # the bars follow every capture
    assert sorted(taken) == list(range(N_PAIRS))
    assert min(bars.values().values()) > 0.0
    assert page.pairs.count_label.text().startswith(f"<b>{N_PAIRS} pairs</b>")
    assert {a.source for a in page.items} == {"cameras"}
    assert sum(a.detection.accepted for a in page.items) == N_PAIRS
    assert page.calibrate()
    qtbot.waitUntil(lambda: not page.task.busy, timeout=90000)
    assert page.result is not None and page.result.pairs_used == N_PAIRS and page.result.file.rms_stereo < 1.0


def test_preview_stops_when_hidden_and_with_the_cameras(page, qtbot, camera_folders):
    open_cameras(page, camera_folders)
    qtbot.waitUntil(lambda: page.live.seen is not None, timeout=WAIT_MS)
    page.hide()
    assert page.live.pump is None and page.live.seen is None and preview_threads() == []
    assert not page.pairs.capture_button.isEnabled()
    page.show()
    qtbot.waitUntil(lambda: page.live.seen is not None, timeout=WAIT_MS)
    page.state.hardware.set_cameras(None)
    assert page.live.pump is None and not page.live.isVisible() and preview_threads() == []
