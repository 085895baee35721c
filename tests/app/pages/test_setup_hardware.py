"""The Setup page on hardware: a serial robot served by the controller simulator on a real pty
(connect, HELLO shown, read joints, a confirmed test move, a move outside the limits refused
before anything is written, Stop and Resume), and two video files / image folders as cameras
with a live preview that keeps the event loop running (no mocks of pyserial or cv2)."""
from __future__ import annotations

import time

import cv2
import numpy as np
import pytest
from PySide6.QtCore import QTimer

from app import messages
from app.pages.setup.page import SetupPage
from app.state import WizardState
from app.worker import TaskRunner
from core.robot.controller_sim import ControllerSim
from core.robot.file import read_robot
from core.robot.model import robot_path
from core.robot.serial_robot import SerialRobot

FRAME = (640, 512)          # px: small test videos (the bench measures 1280x1024)


def write_video(path, frames: int = 30, size=FRAME, shift: int = 0):
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), 30.0, size)
    assert writer.isOpened()
    for i in range(frames):
        img = np.full((size[1], size[0], 3), 40, np.uint8)
        cv2.circle(img, (50 + 15 * i + shift, size[1] // 2), 30, (255, 255, 255), -1)
        writer.write(img)
    writer.release()
    return path


@pytest.fixture
def non_interactive():
    messages.set_non_interactive(True)
    yield
    messages.set_non_interactive(False)


@pytest.fixture
def page(qtbot, tmp_path):
    state, tasks = WizardState(), TaskRunner()
    state.new_project(tmp_path / "project")
    state.choose_preset("educational_6r")
    p = SetupPage(state, tasks)
    qtbot.addWidget(p)
    p.resize(1200, 900)
    p.show()
    p.on_enter()
    yield p
    p.on_leave()
    tasks.shutdown()
    state.close()


@pytest.fixture
def sim():
    model = read_robot(robot_path("educational_6r"))
    with ControllerSim(model, time_scale=0.05) as s:
        yield s


def connect(page, qtbot, port):
    panel = page.robot_panel
    panel.serial_radio.setChecked(True)
    panel.port_edit.setText(port)
    assert panel.connect_robot()
    qtbot.waitUntil(lambda: page.state.hardware.real_robot and not page.task.busy, timeout=10000)
    return panel


def test_a_serial_robot_connects_reads_and_moves_after_confirmation(page, qtbot, sim, non_interactive, capsys):
    panel = connect(page, qtbot, sim.port)
    driver = page.state.hardware.robot_connection
    assert isinstance(driver, SerialRobot) and driver.connected
    assert driver.speed == 25.0                                   # default speed for a real robot
    assert "ROBOCAL" not in panel.info_label.text()              # the controller's name, not the raw line
    assert "Educational" in panel.info_label.text() and "6 joints" in panel.info_label.text()
    assert sim.received[:2] == ["HELLO", "SPEED 25"]
    assert panel.joints is not None and "Joints:" in panel.joints_label.text()

    panel.joint_combo.setCurrentIndex(1)
    assert not page.state.hardware.motion_confirmed
    assert panel.jog(+1)
    assert "first motion" in capsys.readouterr().err              # the confirmation was asked
    qtbot.waitUntil(lambda: not page.task.busy, timeout=10000)
    assert page.state.hardware.motion_confirmed
    assert sim.joints()[1] == pytest.approx(2.0, abs=1e-6)
    assert panel.joints[1] == pytest.approx(np.deg2rad(2.0), abs=1e-6)
    assert [line for line in sim.received if line.startswith("MOVE")] == ["MOVE 0.0000 2.0000 0.0000 0.0000 0.0000 0.0000"]


def test_the_first_motion_is_refused_when_not_confirmed(page, qtbot, sim, monkeypatch):
    panel = connect(page, qtbot, sim.port)
    monkeypatch.setattr(messages, "confirm", lambda *a, **k: False)
    monkeypatch.setattr("app.safety.confirm", lambda *a, **k: False)
    assert not panel.jog(+1)
    assert "not confirmed" in page.status.text()
    time.sleep(0.1)
    assert not any(line.startswith("MOVE") for line in sim.received)


def test_a_move_outside_the_limits_is_refused_before_anything_is_sent(page, qtbot, sim, non_interactive):
    panel = connect(page, qtbot, sim.port)
    model = page.state.robot
    hi = model.limits()[1][0]
    panel.joints = np.array([hi - np.deg2rad(0.5), 0, 0, 0, 0, 0])   # J1 half a degree below its limit
    panel.joint_combo.setCurrentIndex(0)
    sent = list(sim.received)
    assert not panel.jog(+1)
    text = page.status.text()
    assert "J1" in text and "outside its limits" in text and "150.000" in text
    time.sleep(0.1)
    assert sim.received == sent                                   # nothing written to the port
    assert "limits -150.0° … 150.0°" in panel.limits_label.text()


def test_stop_latches_until_resume(page, qtbot, sim, non_interactive):
    panel = connect(page, qtbot, sim.port)
    panel.step_spin.setValue(10.0)
    sim.time_scale = 1.0                                          # a real-time move: 10° at 22.5°/s
    assert panel.jog(+1)
    qtbot.waitUntil(lambda: any(line.startswith("MOVE") for line in sim.received), timeout=5000)
    t = time.monotonic()
    panel.stop_robot()                                            # GUI thread, during the move
    assert time.monotonic() - t < 1.0
    qtbot.waitUntil(lambda: not page.task.busy, timeout=10000)
    assert "STOP" in sim.received and page.state.hardware.robot_connection.stopped
    assert abs(sim.joints()[0]) < 9.9                             # it did not finish the move
    assert "stopped" in panel.info_label.text()
    assert not panel.jog_plus.isEnabled() or not panel.jog(+1)
    moves = sum(line.startswith("MOVE") for line in sim.received)
    assert not panel.jog(+1) and "Resume" in page.status.text()
    assert sum(line.startswith("MOVE") for line in sim.received) == moves
    panel.resume_robot()
    assert not page.state.hardware.robot_connection.stopped
    assert panel.read_joints()
    qtbot.waitUntil(lambda: not page.task.busy, timeout=5000)
    assert panel.jog(+1)
    qtbot.waitUntil(lambda: not page.task.busy, timeout=10000)
    assert sum(line.startswith("MOVE") for line in sim.received) == moves + 1


def test_a_wrong_port_is_one_clear_message(page, qtbot, tmp_path):
    panel = page.robot_panel
    panel.serial_radio.setChecked(True)
    panel.port_edit.setText(str(tmp_path / "no-such-port"))
    assert panel.connect_robot()
    qtbot.waitUntil(lambda: not page.task.busy, timeout=10000)
    assert "no-such-port" in page.status.text() and not page.state.hardware.real_robot


def test_two_video_files_preview_side_by_side_without_blocking(page, qtbot, tmp_path):
    left, right = write_video(tmp_path / "left.avi"), write_video(tmp_path / "right.avi", shift=20)
    panel = page.camera_panel
    panel.left_edit.setText(str(left))
    panel.right_edit.setText(str(right))
    ticks = []
    timer = QTimer()
    timer.timeout.connect(lambda: ticks.append(time.monotonic()))
    timer.start(50)
    assert panel.open_cameras()
    qtbot.waitUntil(lambda: page.state.hardware.cameras is not None, timeout=10000)
    assert panel.pump is not None and panel.pump.running           # the preview starts on its own
    # frames arrive (the bench measures the rate) while the event loop keeps running
    qtbot.waitUntil(lambda: panel.pump.shown >= 10 and len(ticks) >= 40, timeout=15000)
    timer.stop()
    assert max(np.diff(ticks)) < 1.0
    assert not panel.preview.left.pixmap().isNull() and not panel.preview.right.pixmap().isNull()
    assert "left.avi" in panel.status_label.text() and "right.avi" in panel.status_label.text()
    page.on_leave()
    assert panel.pump is None


def test_an_image_folder_and_a_video_file_as_cameras(page, qtbot, tmp_path):
    folder = tmp_path / "right"
    folder.mkdir()
    for i in range(3):
        cv2.imwrite(str(folder / f"img_{i}.png"), np.full((120, 160), 60 * i, np.uint8))
    panel = page.camera_panel
    panel.left_edit.setText(str(write_video(tmp_path / "left.avi", frames=5)))
    panel.right_edit.setText(str(folder))
    assert panel.open_cameras()
    qtbot.waitUntil(lambda: page.state.hardware.cameras is not None and panel.pump is not None
                    and panel.pump.shown >= 8, timeout=10000)       # both loop past their ends
    frames = page.state.hardware.cameras.capture()
    assert frames.left.shape == (FRAME[1], FRAME[0], 3) and frames.right.shape == (120, 160)


def test_a_missing_camera_source_names_it(page, qtbot, tmp_path):
    panel = page.camera_panel
    panel.left_edit.setText(str(tmp_path / "nothing.avi"))
    panel.right_edit.setText("")
    assert panel.open_cameras()
    qtbot.waitUntil(lambda: not page.task.busy, timeout=10000)
    assert "nothing.avi" in page.status.text() and page.state.hardware.cameras is None


def test_camera_settings_are_asked_and_what_did_not_take_is_shown(page, qtbot, tmp_path):
    left, right = write_video(tmp_path / "left.avi", frames=5), tmp_path / "right"
    right.mkdir()
    for i in range(3):
        cv2.imwrite(str(right / f"img_{i}.png"), np.full((120, 160), 60 * i, np.uint8))
    panel = page.camera_panel
    form = panel.settings_form
    assert not form.autofocus_check.isChecked() and form.format_combo.currentData() == "MJPG"
    assert form.settings().width is None and form.width_spin.text() == "camera's"
    form.width_spin.setValue(1280)
    form.height_spin.setValue(1024)
    form.gain_spin.setValue(4)
    panel.left_edit.setText(str(left))
    panel.right_edit.setText(str(right))
    assert panel.open_cameras()
    qtbot.waitUntil(lambda: page.state.hardware.cameras is not None, timeout=10000)
    text = panel.status_label.text()
    assert "Settings that did not take" in text
    assert "the video file refused width = 1280 (it uses 640)" in text
    assert "the image folder cannot take height = 1024 (its images have 120)" in text
    assert "the image folder cannot take gain = 4" in text
    assert "<td align='right'>640</td><td align='right'>160</td>" in text     # actual widths, left and right
