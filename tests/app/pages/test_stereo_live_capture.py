"""The Stereo page's Capture from cameras with the cameras opened on the Setup page (two image
folders of rendered checkerboard pairs as the cameras): each pair is saved numbered into the
project's checkerboard folders and detected; the calibration can be made from them."""
from __future__ import annotations

import cv2
import numpy as np
import pytest
from PySide6.QtCore import Qt

from app.hardware import CameraChoice, LiveCameras
from app.pages.stereo.page import StereoPage
from app.state import WizardState
from app.worker import TaskRunner
from core.project import HARDWARE
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
    assert not button.isEnabled()
    page.state.set_cameras(LiveCameras.open(CameraChoice("sources", str(camera_folders / "left"),
                                                         str(camera_folders / "right"))))
    assert button.isEnabled() and "hold the board still" in button.toolTip()
    for _ in range(N_PAIRS):
        qtbot.mouseClick(button, Qt.MouseButton.LeftButton)
        qtbot.waitUntil(lambda: not page.busy, timeout=30000)
    folder = page.state.project.folder / "checkerboard"
    for side in ("left", "right"):
        assert sorted(p.name for p in (folder / side).iterdir()) == [f"pair_{i:03d}.png" for i in range(N_PAIRS)]
    assert np.array_equal(cv2.imread(str(folder / "left" / "pair_002.png"), cv2.IMREAD_UNCHANGED),
                          cv2.imread(str(camera_folders / "left" / "frame_02.png"), cv2.IMREAD_UNCHANGED))
    assert len(page.items) == N_PAIRS and {a.source for a in page.items} == {"cameras"}
    assert sum(a.detection.detected_ok for a in page.items) >= N_PAIRS - 1
    assert page.calibrate()
    qtbot.waitUntil(lambda: not page.busy, timeout=90000)
    assert page.result is not None and page.result.file.rms_stereo < 1.0
