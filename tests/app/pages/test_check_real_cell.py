"""The Check page on a real cell: `robocal sim-robot` (a subprocess on a real pseudo-terminal) is
the project's robot, and the virtual lab's cameras watching it, written by the simulator into two
image folders after every motion, are the project's cameras. The calibration files are made from
the virtual lab directly (the calibration itself is tested elsewhere); the simulator's robot is
then changed (`--change`). The check drives the robot, is out of limits, the diagnosis names the
change, Re-identify drives the proposed poses and the updated robot checks within limits.
A real-cell project with nothing connected says so and never measures the lab."""
from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from app import messages
from app.hardware import CameraChoice, LiveCameras, RobotChoice, open_serial_robot
from app.lab import ideal_lab_measurements, write_ideal_measurements
from app.pages.check.page import CheckPage
from app.pages.measurement_inputs import marker_file
from app.state import WizardState
from app.worker import TaskRunner
from core import project as projects
from core.identification.file import write_calibrated_model
from core.identification.solver import identify
from core.monitoring.log import read_check_log
from core.robot.file import read_robot
from tests.app.virtual_inputs import lab_marker, make_lab, true_stereo_yaml

ROOT = Path(__file__).resolve().parents[3]
TIMEOUT = 600_000


@pytest.fixture(scope="module")
def lab():
    return make_lab()                      # seed 0: the robot `sim-robot --seed 0` serves


@pytest.fixture
def confirmed():
    """The first-motion question is answered yes (app.messages' non-interactive mode)."""
    messages.set_non_interactive(True)
    yield
    messages.set_non_interactive(False)


@pytest.fixture(scope="module")
def calibration_files(lab, tmp_path_factory) -> dict[str, Path]:
    """The calibration files every test's project starts from, written once (they follow from the
    seed-0 lab alone; each test copies them into its own project): the lab's true rig as
    stereo.yaml, its trained marker, ideal measurements at 50 poses and the robot identified from
    them. Keys: the project's file names for `project.path` (and "marker")."""
    folder = tmp_path_factory.mktemp("calibration")
    files = {"stereo": folder / "stereo.yaml", "marker": folder / "marker.npz",
             "measurements": folder / "measurements.csv", "calibrated": folder / "calibrated.json"}
    true_stereo_yaml(lab, files["stereo"])
    lab_marker(lab).save(files["marker"])
    meas = ideal_lab_measurements(lab, 50, sigma_mm=0.05, seed=4)
    write_ideal_measurements(meas, files["measurements"], sigma_mm=0.05)
    write_calibrated_model(identify(lab.nominal_robot, meas), files["calibrated"])
    return files


@pytest.fixture
def calibrated_project(calibration_files):
    """calibrated_project(folder, cell): a real-cell project of the educational 6R arm with its
    stereo.yaml (the lab's true rig), its trained marker, its measurements and the calibration
    identified from them (copies of `calibration_files`)."""
    def make(folder: Path, cell: dict) -> WizardState:
        state = WizardState(seed=0, noise=0.5)
        state.new_project(folder, mode=projects.HARDWARE, **cell)
        state.choose_preset("educational_6r")
        project = state.project
        for name in ("stereo", "measurements", "calibrated"):
            shutil.copyfile(calibration_files[name], project.path(name))
        shutil.copyfile(calibration_files["marker"], marker_file(project))
        return state
    return make


def start_sim_robot(folder: Path, cameras: Path, change: str):
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    proc = subprocess.Popen([sys.executable, "-m", "app.cli", "sim-robot", "--seed", "0", "--time-scale", "0.01",
                             "--duration", "900", "--cameras", str(cameras), "--change", change],
                            cwd=folder, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    port = proc.stdout.readline().strip()
    if not port.startswith("/dev/"):
        proc.kill()
        pytest.fail(f"sim-robot printed no device: {port!r} {proc.stderr.read()}")
    return proc, port


def open_page(qtbot, state: WizardState, tasks: TaskRunner) -> CheckPage:
    page = CheckPage(state, tasks)
    qtbot.addWidget(page)
    page.resize(1100, 760)
    page.show()
    page.on_enter()
    return page


def wait(page, qtbot) -> None:
    qtbot.waitUntil(lambda: not page.task.busy, timeout=TIMEOUT)


def test_a_tool_change_on_the_serial_robot_is_found_and_reidentified(qtbot, tmp_path, calibrated_project, confirmed):
    cameras = tmp_path / "cell-cameras"
    proc, port = start_sim_robot(tmp_path, cameras, "tool:1.5")
    cell = {"robot_connection": {"kind": "serial", "port": port, "profile": "robocal_v1"},
            "cameras": {"kind": "sources", "left": str(cameras / "left"), "right": str(cameras / "right")}}
    state, tasks = calibrated_project(tmp_path / "project", cell), TaskRunner()
    try:
        choice = RobotChoice("serial", port, "robocal_v1")
        state.hardware.use_serial_robot(open_serial_robot(state.robot, choice, reply_timeout=10.0), choice)
        state.hardware.set_cameras(LiveCameras.open(CameraChoice("sources", str(cameras / "left"), str(cameras / "right"))))
        page = open_page(qtbot, state, tasks)
        assert not page.controls.change_box.isVisible()          # a real cell is never changed by simulation
        assert page.controls.cell_label.text() == (f"Measures on a real cell: the serial robot on {port} (robocal_v1), "
                                                   f"cameras {cameras / 'left'} and {cameras / 'right'}.")
        before = page.calibrated_path().read_text()

        assert page.run_check()
        qtbot.waitUntil(lambda: page.result is not None and not page.task.busy, timeout=TIMEOUT)
        driver = state.hardware.robot_connection
        result, diagnosis = page.result, page.diagnosis
        assert len(page.cell.Q) == 8 and len(result.points) == 8, page.status.text()
        np.testing.assert_allclose(driver.current_joints(), page.cell.Q[-1], atol=1e-4)    # the robot moved there
        assert not result.within and diagnosis is not None and diagnosis.kind == "tool", page.status.text()
        assert diagnosis.text.startswith("The marker moved 1.5 mm") or "1.5" in diagnosis.text, diagnosis.text
        status = page.status.text()
        assert f"measured with the serial robot on {port} and images from the folders" in status, status
        assert "virtual lab" not in status
        assert page.results.reidentify_button.isEnabled()
        log = read_check_log(page.log_path())
        assert len(log.checks) == 1 and len(log.checks[0].points) == 8 and not log.checks[0].within

        assert page.reidentify()
        qtbot.waitUntil(lambda: page.reidentification is not None and not page.task.busy, timeout=TIMEOUT)
        update = page.reidentification
        assert len(update.proposed) >= 1 and update.after.within, page.status.text()
        assert page.result.within and "Re-identified marker.x" in page.status.text()
        assert f"serial robot on {port}" in page.status.text()
        written = read_robot(page.calibrated_path())
        assert written.calibration["history"][-1]["changed"] == ["marker.x", "marker.y", "marker.z"]
        assert any((page.calibrated_path().parent / "history").iterdir())
        assert page.calibrated_path().read_text() != before

        shot = tmp_path / "check-real-cell.png"          # docs/screenshots/check-real-cell.png
        page.grab().save(str(shot))
        assert shot.stat().st_size > 10_000
    finally:
        tasks.shutdown()
        state.close()
        proc.terminate()
        proc.wait(timeout=20)
    assert np.isfinite(update.after.rms_mm)


def test_a_real_cell_with_nothing_connected_says_so_and_measures_nothing(qtbot, tmp_path, calibrated_project):
    state = calibrated_project(tmp_path / "project", {
        "robot_connection": {"kind": "serial", "port": "/dev/ttyUSB0", "profile": "robocal_v1"},
        "cameras": {"kind": "sources", "left": "0", "right": "2"}})
    tasks = TaskRunner()
    try:
        page = open_page(qtbot, state, tasks)
        assert state.hardware.robot_connection is None and not state.labs.built
        assert "a real cell: the serial robot on /dev/ttyUSB0" in page.status.text()
        assert "no robot is connected" in page.status.text()
        assert not page.run_check()
        assert "Nothing measured: no robot is connected" in page.status.text()
        assert "never on the virtual lab" in page.status.text()
        assert not page.task.busy and not state.labs.built and page.result is None
        assert not page.log_path().exists()
        assert not page.choose_poses() and not page.task.busy
    finally:
        tasks.shutdown()
        state.close()


def test_a_robot_fault_ends_a_scheduled_check_keeping_the_log(lab, qtbot, tmp_path, calibrated_project, confirmed):
    """The controller simulator on a pty (in this process), faulting on its third move; the lab's
    cameras watch it through two image folders. The scheduled check stops there, the schedule is
    switched off, and the two points measured stay in the log."""
    from app.sim_cameras import SimulatedCellCameras
    from core.robot.controller_sim import ControllerSim

    cameras = SimulatedCellCameras(lab, tmp_path / "cell-cameras")
    sim = ControllerSim(lab.true_robot, faults="fault@3", time_scale=0.01, on_rest=cameras.on_rest).start()
    cell = {"robot_connection": {"kind": "serial", "port": sim.port, "profile": "robocal_v1"},
            "cameras": {"kind": "sources", "left": str(cameras.left), "right": str(cameras.right)}}
    state, tasks = calibrated_project(tmp_path / "project", cell), TaskRunner()
    try:
        choice = RobotChoice("serial", sim.port, "robocal_v1")
        state.hardware.use_serial_robot(open_serial_robot(state.robot, choice, reply_timeout=10.0), choice)
        state.hardware.set_cameras(LiveCameras.open(CameraChoice("sources", str(cameras.left), str(cameras.right))))
        page = open_page(qtbot, state, tasks)
        page.controls.schedule_check.setChecked(True)
        assert page.schedule_timer.isActive()
        page.schedule.tick()                        # the timer's tick
        qtbot.waitUntil(lambda: page.result is not None and not page.task.busy, timeout=TIMEOUT)
        assert sim.fired == ["fault@3"] and page.result.cancelled
        assert len(page.result.points) == 2, page.status.text()
        assert "Robot fault: " in page.status.text() and "scheduled checks are off" in page.status.text()
        assert not page.controls.schedule_check.isChecked() and not page.schedule_timer.isActive()
        assert state.hardware.robot_connection.stopped
        log = read_check_log(page.log_path())
        assert len(log.checks) == 1 and len(log.checks[0].points) == 2 and not log.checks[0].finished
        assert not page.run_check() and "stopped" in page.status.text()     # nothing moves before Resume
    finally:
        tasks.shutdown()
        state.close()
        sim.close()


def test_teach_mode_records_each_check_pose_by_hand(lab, qtbot, tmp_path, calibrated_project):
    """No robot connection: the technician brings the robot to each listed pose (here the lab's
    cameras are rendered where it was brought) and types the joints; the recorded poses are checked
    and logged, within limits for the unchanged robot."""
    from app.sim_cameras import SimulatedCellCameras

    cameras = SimulatedCellCameras(lab, tmp_path / "cell-cameras")
    cameras.on_rest(np.zeros(6))
    cell = {"robot_connection": {"kind": "teach"},
            "cameras": {"kind": "sources", "left": str(cameras.left), "right": str(cameras.right)}}
    state, tasks = calibrated_project(tmp_path / "project", cell), TaskRunner()
    try:
        state.hardware.set_cameras(LiveCameras.open(CameraChoice("sources", str(cameras.left), str(cameras.right))))
        page = open_page(qtbot, state, tasks)
        assert page.teach.isVisible() and not page.controls.schedule_check.isEnabled()
        assert page.run_check()                     # the poses are chosen first
        wait(page, qtbot)
        assert page.cell is not None and page.controls.poses_list.count() == 8
        assert "Bring the robot to <b>pose 0</b>" in page.teach.next_label.text()
        page.teach.joints_edit.setText("1, 2, 3")
        assert not page.record_pose() and "3 joint values typed, the robot has 6" in page.status.text()
        for k, q in enumerate(page.cell.Q):
            q_file = page.cell.model.q_to_file(q) + 0.3          # where the technician brought it
            cameras.on_rest(q_file)
            page.teach.joints_edit.setText(" ".join(f"{v:.4f}" for v in q_file))
            assert page.record_pose(), page.status.text()
            wait(page, qtbot)
            assert f"Pose {k} recorded: marker located" in page.status.text()
        assert page.teach.check_button.isEnabled()
        assert page.run_check()
        qtbot.waitUntil(lambda: page.result is not None and not page.task.busy, timeout=TIMEOUT)
        assert page.result.within and len(page.result.points) == 8, page.status.text()
        assert "brought to each pose by hand (teach mode)" in page.status.text()
        logged = read_check_log(page.log_path()).checks[0].points
        np.testing.assert_allclose(logged[0].q_file, page.cell.model.q_to_file(page.cell.Q[0]) + 0.3, atol=1e-3)
    finally:
        tasks.shutdown()
        state.close()


def test_the_fixture_panel_works_in_a_real_cell_project(lab, qtbot, tmp_path, calibrated_project):
    """Nothing connected: the fixture is located from its description and a folder of pairs (the
    lab's fixture is not offered)."""
    import cv2

    from app.lab import place_fixture, render_fixture_pairs
    from core.fixtures.description import write_fixture_description

    state = calibrated_project(tmp_path / "project", {"robot_connection": {"kind": "teach"}})
    tasks = TaskRunner()
    try:
        page = open_page(qtbot, state, tasks)
        panel = page.fixture
        assert panel.source == "files" and not panel.source_combo.model().item(0).isEnabled()
        assert panel.locate_button.isEnabled() and panel.pairs_button.isEnabled()
        fixture = place_fixture(lab, points=[[0, 0, 0], [200, 0, 0], [60, 150, 0]])
        write_fixture_description(tmp_path / "fixture.json", fixture.description(with_positions=False))
        for side in ("left", "right"):
            (tmp_path / "pairs" / side).mkdir(parents=True)
        for name, (left, right) in zip(fixture.names, render_fixture_pairs(lab, fixture, 2)):
            cv2.imwrite(str(tmp_path / "pairs" / "left" / f"{name}.png"), left)
            cv2.imwrite(str(tmp_path / "pairs" / "right" / f"{name}.png"), right)
        panel.description_path, panel.pairs_folder = str(tmp_path / "fixture.json"), str(tmp_path / "pairs")
        assert page.locate_fixture()
        wait(page, qtbot)
        frame = page.fixture_run.result.frame
        assert np.linalg.norm(frame.position - fixture.pose[:3, 3]) < 0.2, page.status.text()
        assert (state.project.folder / "fixture_pose.json").is_file() and not state.labs.built
    finally:
        tasks.shutdown()
        state.close()


def test_stop_ends_a_check_on_the_cell(lab, qtbot, tmp_path, calibrated_project, confirmed):
    """The Stop key (the main window's Stop calls state.hardware.stop_robot) during a check: the robot halts,
    the check ends with the points measured kept, nothing moves until Resume."""
    from app.sim_cameras import SimulatedCellCameras
    from core.robot.controller_sim import ControllerSim

    cameras = SimulatedCellCameras(lab, tmp_path / "cell-cameras")
    sim = ControllerSim(lab.true_robot, time_scale=0.05, on_rest=cameras.on_rest).start()
    cell = {"robot_connection": {"kind": "serial", "port": sim.port, "profile": "robocal_v1"},
            "cameras": {"kind": "sources", "left": str(cameras.left), "right": str(cameras.right)}}
    state, tasks = calibrated_project(tmp_path / "project", cell), TaskRunner()
    try:
        choice = RobotChoice("serial", sim.port, "robocal_v1")
        state.hardware.use_serial_robot(open_serial_robot(state.robot, choice, reply_timeout=10.0), choice)
        state.hardware.set_cameras(LiveCameras.open(CameraChoice("sources", str(cameras.left), str(cameras.right))))
        page = open_page(qtbot, state, tasks)
        assert page.run_check()
        qtbot.waitUntil(lambda: sim.moves >= 3, timeout=TIMEOUT)
        assert state.hardware.stop_robot()
        qtbot.waitUntil(lambda: page.result is not None and not page.task.busy, timeout=TIMEOUT)
        moves = sim.moves
        assert page.result.cancelled and 2 <= len(page.result.points) < 8, page.status.text()
        assert "The robot was stopped. The run ended there" in page.status.text()
        assert "Robot fault" not in page.status.text()
        assert len(read_check_log(page.log_path()).checks[0].points) == len(page.result.points)
        assert not page.run_check() and "The robot is stopped" in page.status.text() and sim.moves == moves
    finally:
        tasks.shutdown()
        state.close()
        sim.close()
