"""The Marker page with cameras opened on the Setup page (image folders as the two cameras,
in a hardware project): the training image comes from the left camera, the live pair from both;
the marker is located where the lab put it."""
from __future__ import annotations

import cv2
import numpy as np
import pytest

from app.hardware import CameraChoice, LiveCameras
from app.pages.marker.page import MarkerPage
from app.state import WizardState
from app.worker import TaskRunner
from core.project import HARDWARE
from tests.app.virtual_inputs import lab_marker, make_lab, true_stereo_yaml


@pytest.fixture(scope="module")
def lab():
    return make_lab()


@pytest.fixture
def page(qtbot, lab, tmp_path):
    state, tasks = WizardState(), TaskRunner()
    state.new_project(tmp_path / "project", mode=HARDWARE)
    state.choose_preset("educational_6r")
    true_stereo_yaml(lab, state.project.path("stereo"))
    p = MarkerPage(state, tasks)
    qtbot.addWidget(p)
    p.resize(1100, 800)
    p.show()
    p.on_enter()
    yield p
    tasks.shutdown()
    state.close()


def camera_folders(lab, q, root):
    """Frame 0: the marker plate facing the left camera; frame 1: the marker on the robot at q."""
    training = lab.render_training_image()
    left, right = lab.render_marker_pair(q, np.random.default_rng(4))
    for side, frames in (("left", (training, left)), ("right", (training, right))):
        (root / side).mkdir(parents=True)
        for i, img in enumerate(frames):
            cv2.imwrite(str(root / side / f"{i}.png"), img)
    return LiveCameras.open(CameraChoice("sources", str(root / "left"), str(root / "right")))


def test_training_image_and_live_pair_from_the_cameras(page, qtbot, lab, tmp_path):
    tp, lp = page.training_panel, page.live_panel
    assert not tp.capture_button.isEnabled()
    q = lab.random_visible_poses(1, np.random.default_rng(9))[0]
    page.state.hardware.set_cameras(camera_folders(lab, q, tmp_path / "cams"))
    assert tp.capture_button.isEnabled() and tp.capture_button.text() == "Capture (left camera)"
    assert page.capture_training()
    qtbot.waitUntil(lambda: not page.task.busy, timeout=30000)
    assert page.model.result.training_image is not None and page.model.result.training_image.source == "left camera"
    tp.size_spin.setValue(lab.marker.outer_size)
    assert page.train()
    qtbot.waitUntil(lambda: not page.task.busy and page.model.result.trained is not None, timeout=60000)
    assert lp.next_button.isEnabled() and lp.next_button.text() == "Capture pair"
    assert page.next_pose()
    qtbot.waitUntil(lambda: not page.task.busy, timeout=60000)
    loc = page.model.result.live.location
    assert loc.ok and page.model.result.live.truth is None
    assert np.linalg.norm(loc.point - lab.marker_position(q)) < 2.0          # mm
    assert "Located" in page.status.text() and "truth" not in page.status.text()
    assert not page.verification_panel.verify_button.isEnabled()           # verification needs the lab's truth
    words = " ".join(w.text() + " " + w.toolTip() for w in (tp.capture_button, lp.next_button)).lower()
    assert "issue" not in words and "not yet" not in words


def test_next_pose_moves_a_serial_robot_only_once_its_first_motion_is_confirmed(qtbot, lab, monkeypatch):
    from app import safety
    from app.hardware import RobotChoice, open_serial_robot
    from core.robot.controller_sim import ControllerSim
    from tests.app.virtual_inputs import lab_state

    state, tasks = lab_state(lab), TaskRunner()
    lab_marker(lab).save(state.project.folder / "marker.npz")
    with ControllerSim(lab.true_robot, time_scale=0.01) as sim:
        choice = RobotChoice("serial", sim.port)
        state.hardware.use_serial_robot(open_serial_robot(state.robot, choice, reply_timeout=5.0), choice)
        page = MarkerPage(state, tasks)
        qtbot.addWidget(page)
        page.on_enter()
        try:
            answers = [False, True]
            monkeypatch.setattr(safety, "confirm", lambda *a, **k: answers.pop(0))
            assert not page.next_pose()
            assert "not confirmed" in page.status.text()
            assert not any(line.startswith("MOVE") for line in sim.received)
            assert page.next_pose()
            qtbot.waitUntil(lambda: not page.task.busy, timeout=60000)
            assert sum(line.startswith("MOVE") for line in sim.received) == 1
            live = page.model.result.live
            assert live.location.ok and live.error < 1.0                      # rendered at the reported joints
            assert page.next_pose()                                           # asked once per connection
            qtbot.waitUntil(lambda: not page.task.busy, timeout=60000)
            assert sum(line.startswith("MOVE") for line in sim.received) == 2 and answers == []
        finally:
            tasks.shutdown()
            state.close()
