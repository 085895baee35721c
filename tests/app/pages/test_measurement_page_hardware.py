"""The Measurement page over hardware, driven by pytest-qt: a serial robot (the controller
simulator on a real pty) and as cameras image folders (pairs the virtual lab rendered at the
planned poses) or the lab's renderer at the joints the controller reports. A hardware project
measures every pose; a disconnect mid-run keeps what was measured and Resume finishes after
reconnecting; teach mode records a typed pose and refuses one outside the joint limits."""
from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest
from PySide6.QtCore import Qt

from app import messages
from app.hardware import CameraChoice, LiveCameras, RobotChoice, open_serial_robot
from app.jobs.measurement import MEASURED, PENDING
from app.pages.measurement.page import MeasurementPage
from app.state import WizardState
from app.worker import TaskRunner
from core.errors import RoboCalError
from core.measurement.file import read_measurements
from core.measurement.run import rejects_path_for
from core.poses.file import write_poses
from core.project import HARDWARE
from core.robot.controller_sim import ControllerSim
from tests.app.jobs.test_measurement_hardware import rendered_folders
from tests.app.virtual_inputs import lab_marker, lab_state, make_lab, true_stereo_yaml
from tests.app.windows import close_window

N_POSES = 10


@pytest.fixture(scope="module")
def lab():
    return make_lab()


@pytest.fixture(scope="module")
def trained(lab):
    return lab_marker(lab)


@pytest.fixture(scope="module")
def Q(lab):
    return lab.random_visible_poses(N_POSES, np.random.default_rng(5))


@pytest.fixture(autouse=True)
def nobody_at_the_screen():
    """The first-motion question is answered yes (app.messages' non-interactive mode)."""
    messages.set_non_interactive(True)
    yield
    messages.set_non_interactive(False)


def prepare(state, lab, trained, Q):
    trained.save(state.project.folder / "marker.npz")
    true_stereo_yaml(lab, state.project.path("stereo"))
    write_poses(state.project.path("poses"), lab.nominal_robot.q_to_file(Q))


@pytest.fixture(scope="module")
def camera_folders(lab, Q, tmp_path_factory) -> Path:
    """The image folders (left/, right/) of the pairs the lab's cameras see at the planned poses,
    rendered once (deterministic: the module's lab, poses and seed); each test opens a copy."""
    folder = tmp_path_factory.mktemp("cams") / "cams"
    rendered_folders(lab, Q, folder).close()
    return folder


@pytest.fixture
def hardware(qtbot, lab, trained, Q, camera_folders, tmp_path):
    """A hardware project (no virtual lab) with its cameras open on image folders (a copy of
    `camera_folders`)."""
    state = WizardState(seed=0)
    state.new_project(tmp_path / "project", mode=HARDWARE)
    state.choose_preset("educational_6r")
    prepare(state, lab, trained, Q)
    cams = shutil.copytree(camera_folders, tmp_path / "cams")
    state.hardware.set_cameras(LiveCameras.open(CameraChoice("sources", str(cams / "left"), str(cams / "right"))))
    yield state
    state.close()


def open_page(qtbot, state, tasks) -> MeasurementPage:
    page = MeasurementPage(state, tasks)
    qtbot.addWidget(page)
    page.resize(1000, 800)
    page.show()
    page.on_enter()
    return page


def measured_ids(page) -> list[int]:
    path = page.measurements_path()
    try:
        return [int(p) for p in read_measurements(path).pose] if path.is_file() else []
    except RoboCalError:                    # the header only: the run just began
        return []


def test_a_hardware_project_measures_every_pose_over_a_pty(qtbot, hardware, lab, Q, tmp_path, boxes):
    state, tasks = hardware, TaskRunner()
    page = open_page(qtbot, state, tasks)
    assert page.teach_mode and page.teach.isVisible()           # no robot yet: RoboCal cannot move it
    with ControllerSim(lab.true_robot, time_scale=0.01) as sim:
        choice = RobotChoice("serial", sim.port)
        state.hardware.use_serial_robot(open_serial_robot(state.robot, choice), choice)
        try:
            assert not page.teach_mode and not page.teach.isVisible() and page.views.isVisible()
            assert page.controls.teach_check.isEnabled() and not page.controls.teach_check.isChecked()
            qtbot.mouseClick(page.controls.start_button, Qt.MouseButton.LeftButton)
            assert page.task.busy and state.hardware.motion_confirmed             # the first motion was confirmed
            qtbot.waitUntil(lambda: not page.task.busy, timeout=60000)
            page.grab().save(str(tmp_path / "measurement-hardware.png"))
        finally:
            state.hardware.robot_connection.disconnect()
    ids = measured_ids(page)
    assert sorted(ids) == list(range(N_POSES)), page.status.text()          # every pose, once
    assert sum(line.startswith("MOVE") for line in sim.received) == N_POSES
    assert [r.status for r in page.rows] == [MEASURED] * N_POSES and page.is_complete()
    assert "✓ Done" in page.status.text() and state.measurements == page.measurements_path()
    assert page.pair.thumb.image_shape()[1] > 600
    meas = read_measurements(page.measurements_path())
    truth = np.array([lab.marker_position(q) for q in Q])
    assert np.max(np.linalg.norm(meas.xyz - truth, axis=1)) < 5.0        # mm, left camera frame
    assert boxes == []
    tasks.shutdown()


def test_a_disconnect_keeps_what_was_measured_and_resume_finishes(qtbot, lab, trained, Q, tmp_path, boxes):
    """Virtual-lab project, serial robot, the lab's cameras rendering at the reported joints."""
    state, tasks = lab_state(lab), TaskRunner()
    prepare(state, lab, trained, Q)
    link = tmp_path / "robot"
    with ControllerSim(lab.true_robot, time_scale=0.01, faults="disconnect@3", link=link) as sim:
        choice = RobotChoice("serial", str(link))
        state.hardware.use_serial_robot(open_serial_robot(state.robot, choice), choice)
        try:
            page = open_page(qtbot, state, tasks)
            stopped_seen = []
            state.hardware.stoppedChanged.connect(stopped_seen.append)
            assert not page.teach_mode and page.start_run()
            qtbot.waitUntil(lambda: not page.task.busy, timeout=60000)
            text = page.status.text()
            assert "Stopped before pose 3" in text and "connection is lost" in text, text
            assert state.hardware.robot_connection.stopped and stopped_seen == [True]      # the window offers Resume
            assert "Measure the rest starts at pose 3" in text and "Setup page" in text
            assert sorted(measured_ids(page)) == [0, 1, 2]                   # kept on disk
            assert [r.pose for r in page.rows if r.status == PENDING] == list(range(3, N_POSES))
            assert page.controls.start_button.text() == "Measure the rest"
            page.grab().save(str(tmp_path / "measurement-fault.png"))
            # not reconnected yet: refused, nothing sent
            moves = sum(line.startswith("MOVE") for line in sim.received)
            assert not page.start_run() and "connection to the robot is lost" in page.status.text()
            qtbot.wait(400)                                              # the controller comes back
            state.hardware.use_serial_robot(open_serial_robot(state.robot, choice), choice)
            assert not state.hardware.motion_confirmed
            qtbot.mouseClick(page.controls.start_button, Qt.MouseButton.LeftButton)
            qtbot.waitUntil(lambda: not page.task.busy, timeout=60000)
        finally:
            state.hardware.robot_connection.disconnect()
    ids = measured_ids(page)
    assert sorted(ids) == list(range(N_POSES)), page.status.text()          # each pose exactly once
    assert sum(line.startswith("MOVE") for line in sim.received) == moves + N_POSES - 3
    assert page.result.fault is None and "✓ Done" in page.status.text()
    assert boxes == []
    tasks.shutdown()
    state.close()


def test_teach_mode_records_a_typed_pose_and_refuses_one_outside_the_limits(qtbot, hardware, lab, Q, tmp_path):
    state, tasks = hardware, TaskRunner()
    page = open_page(qtbot, state, tasks)
    model = state.robot
    assert state.hardware.robot_connection is None and page.teach_mode
    assert page.teach.isVisible() and not page.views.isVisible()
    check = page.controls.teach_check
    assert check.isChecked() and not check.isEnabled()
    assert not page.controls.start_button.isEnabled() and page.teach.record_button.isEnabled()
    assert not page.teach.read_check.isEnabled()                     # no controller to read
    assert "Next pose: 0" in page.teach.pose_label.text() and "Teach mode" in page.status.text()
    assert len(page.teach.top.arm.getData()[0]) > 6                  # the nominal arm in the pose
    planned = model.q_to_file(Q[0])
    # outside the limits: said while typing, refused, nothing written
    bad = planned.copy()
    bad[2] = 500.0
    page.teach.joints_edit.setText(" ".join(f"{v:.3f}" for v in bad))
    assert "J3: 500.000° is outside its limits" in page.teach.check_label.text()
    qtbot.mouseClick(page.teach.record_button, Qt.MouseButton.LeftButton)
    assert not page.task.busy and "Pose 0 not recorded" in page.status.text() and "outside its limits" in page.status.text()
    assert not page.measurements_path().exists() and not rejects_path_for(page.measurements_path()).exists()
    # the values the pendant shows, J2 2° off the plan: warned, recorded
    typed = planned + np.array([0, 2.0, 0, 0, 0, 0])
    page.teach.joints_edit.setText(", ".join(f"{v:.3f}" for v in typed))
    assert "J2 is 2.00° from the planned pose" in page.teach.check_label.text()
    assert "Inside the joint limits" in page.teach.check_label.text()
    qtbot.mouseClick(page.teach.record_button, Qt.MouseButton.LeftButton)
    assert page.task.busy
    qtbot.waitUntil(lambda: not page.task.busy, timeout=30000)
    assert measured_ids(page) == [0], page.status.text()
    np.testing.assert_allclose(read_measurements(page.measurements_path()).q_file[0], typed, atol=1e-3)
    assert page.rows[0].status == MEASURED and page.pair.thumb.image_shape()[1] > 600
    assert "✓ Pose 0 recorded (J2 is 2.00° from the planned pose). Next: pose 1." in page.status.text()
    assert "Next pose: 1" in page.teach.pose_label.text() and page.teach.joints_edit.text() == ""
    page.teach.joints_edit.setText("")
    qtbot.mouseClick(page.teach.plan_button, Qt.MouseButton.LeftButton)     # the planned values, to correct
    np.testing.assert_allclose([float(v) for v in page.teach.joints_edit.text().split()], model.q_to_file(Q[1]),
                               atol=1e-3)
    page.grab().save(str(tmp_path / "measurement-teach.png"))
    tasks.shutdown()


def test_the_stop_key_ends_a_run_over_a_pty(qtbot, hardware, lab):
    from PySide6.QtWidgets import QApplication

    from app.main_window import MainWindow
    from app.pages.steps import Step

    state = hardware
    win = MainWindow(state)
    qtbot.addWidget(win)
    with ControllerSim(lab.true_robot, time_scale=0.05) as sim:
        choice = RobotChoice("serial", sim.port)
        state.hardware.use_serial_robot(open_serial_robot(state.robot, choice), choice)
        try:
            win.show()
            page = win.go_to(Step.MEASUREMENT)
            assert page.start_run()
            qtbot.waitUntil(lambda: len(measured_ids(page)) >= 1, timeout=30000)
            win.activateWindow()
            qtbot.waitUntil(lambda: QApplication.activeWindow() is win, timeout=5000)
            qtbot.keyClick(win, Qt.Key.Key_Escape)
            assert state.hardware.robot_connection.stopped and "STOP" in sim.received
            moves = sum(line.startswith("MOVE") for line in sim.received)
            qtbot.waitUntil(lambda: not page.task.busy, timeout=30000)
            assert sum(line.startswith("MOVE") for line in sim.received) == moves      # nothing sent after Stop
            assert "Robot stopped" in page.status.text() and "Resume after stop" in page.status.text()
            first = measured_ids(page)
            assert first and len(first) < N_POSES
            sim.time_scale = 0.01       # slow motions only for the Stop key to land in one; the rest at test speed
            win.resume_robot()
            assert page.start_run()
            qtbot.waitUntil(lambda: not page.task.busy, timeout=60000)
            assert sorted(measured_ids(page)) == list(range(N_POSES)), page.status.text()
        finally:
            state.hardware.robot_connection.disconnect()
            close_window(win)


def test_teach_mode_reads_the_joints_from_the_controller(qtbot, hardware, lab, Q):
    """A robot RoboCal could move, taught by choice: its joints are read at the capture."""
    state, tasks = hardware, TaskRunner()
    page = open_page(qtbot, state, tasks)
    with ControllerSim(lab.true_robot, time_scale=0.01) as sim:
        choice = RobotChoice("serial", sim.port)
        state.hardware.use_serial_robot(open_serial_robot(state.robot, choice), choice)
        try:
            assert not page.teach_mode and page.controls.teach_check.isEnabled()
            page.controls.teach_check.setChecked(True)
            assert page.teach_mode and page.teach.isVisible() and not page.controls.start_button.isEnabled()
            assert page.teach.read_check.isChecked() and not page.teach.joints_edit.isEnabled()
            state.hardware.robot_connection.move_to(Q[0])                     # the technician's pendant
            moves = sum(line.startswith("MOVE") for line in sim.received)
            assert page.record_pose()
            qtbot.waitUntil(lambda: not page.task.busy, timeout=30000)
            assert sum(line.startswith("MOVE") for line in sim.received) == moves    # RoboCal moved nothing
            assert "✓ Pose 0 recorded. Next: pose 1." in page.status.text()
            page.controls.teach_check.setChecked(False)
            assert not page.teach_mode and page.views.isVisible() and page.controls.start_button.isEnabled()
        finally:
            state.hardware.robot_connection.disconnect()
    assert measured_ids(page) == [0], page.status.text()
    np.testing.assert_allclose(read_measurements(page.measurements_path()).q_file[0],
                               state.robot.q_to_file(Q[0]), atol=1e-3)
    tasks.shutdown()
