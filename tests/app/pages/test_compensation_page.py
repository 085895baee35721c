"""The Compensation page on the virtual lab: a typed point gets nominal and corrected joints and a
predicted error, Go to point lands within a few predicted errors of it (measured through the
rendered images), a fixture-relative point needs a located fixture, a program taught with the
nominal model and a targets file are corrected and written, an unreachable point is named and never written, and the
accuracy map is measured, saved, drawn and read back by a new page."""
from __future__ import annotations

import numpy as np
import pytest
from PySide6.QtCore import Qt

from app.lab import ideal_lab_measurements, write_ideal_measurements
from app.pages.compensation.page import MISSING, CompensationPage
from app.worker import TaskRunner
from core.compensation.accuracy_map_file import read_accuracy_map
from core.identification.file import write_calibrated_model
from core.identification.solver import identify
from core.fixtures.file import write_fixture_pose
from core.fixtures.frame import FixtureFrame
from core.poses.file import read_poses, write_poses
from core.transforms import make_transform, rot_axis
from tests.app.virtual_inputs import lab_marker, lab_state, make_lab

TIMEOUT = 240_000


@pytest.fixture(scope="module")
def lab():
    return make_lab()


@pytest.fixture
def state(lab, qtbot):
    s = lab_state(lab)
    s.set_marker(lab_marker(lab))
    yield s
    s.close()


@pytest.fixture
def tasks():
    t = TaskRunner()
    yield t
    t.shutdown()


def calibrate(state, lab):
    meas = ideal_lab_measurements(lab, 50, sigma_mm=0.05, seed=4)
    write_ideal_measurements(meas, state.project.path("measurements"), sigma_mm=0.05)
    write_calibrated_model(identify(lab.nominal_robot, meas), state.project.path("calibrated"))
    return meas


def open_page(qtbot, state, tasks) -> CompensationPage:
    p = CompensationPage(state, tasks)
    qtbot.addWidget(p)
    p.resize(1300, 860)
    p.show()
    p.on_enter()
    return p


def wait(page, qtbot):
    qtbot.waitUntil(lambda: not page.task.busy, timeout=TIMEOUT)


def test_missing_calibration_is_said_plainly(state, tasks, qtbot):
    page = open_page(qtbot, state, tasks)
    assert page.status.text() == MISSING
    assert not page.add_point((0, 0, 600)) and not page.measure_map()
    assert not page.panel.add_button.isEnabled() and not page.map_panel.measure_button.isEnabled()


def test_typed_point_go_to_point_and_program(state, lab, tasks, qtbot, tmp_path):
    meas = calibrate(state, lab)
    page = open_page(qtbot, state, tasks)
    target = lab.true_robot.target_position(meas.Q[3], "marker")          # a point the cameras saw
    for spin, value in zip((page.panel.x_spin, page.panel.y_spin, page.panel.z_spin), target):
        spin.setValue(value)
    page.panel.frame_combo.setCurrentIndex(1)                  # the camera frame
    assert page.panel.frame == "camera"
    qtbot.mouseClick(page.panel.add_button, Qt.MouseButton.LeftButton)
    wait(page, qtbot)
    p = page.points[0]
    np.testing.assert_allclose(p.target, target, atol=0.006)    # the spin boxes keep 0.01 mm
    assert p.reachable and 0 < p.predicted_mm < 0.5, page.status.text()
    assert not np.allclose(p.q_nominal, p.q_corrected)        # the calibration changes the joints
    assert page.table.rowCount() == 1 and page.table.item(0, 4).text() == f"{p.predicted_mm:.3f}"
    assert page.go_to_point(0)
    wait(page, qtbot)
    landed = page.points[0]
    assert landed.landed is not None and "rendered camera images" in landed.measured_by, page.status.text()
    assert landed.error_mm() < 0.5 and "calibrated model: the marker landed" in page.status.text()
    # the same point with the nominal joints (what the controller alone does) misses by millimetres
    page.panel.nominal_check.setChecked(True)
    assert page.go_to_point(0)
    wait(page, qtbot)
    both = page.points[0]
    assert both.error_mm(nominal=True) > 1.0 and both.error_mm() == landed.error_mm()
    assert page.table.item(0, 6).text() == f"{both.error_mm(nominal=True):.3f}"
    np.testing.assert_allclose(both.landed_nominal, lab.marker_position(p.q_nominal), atol=0.3)

    # a point on the fixture needs a located fixture
    assert not page.add_point((0, 0, 0), "fixture") and "Locate the fixture" in page.status.text()
    # a fixture located in the robot base frame: a point typed on it lands where it is meant
    T = make_transform(rot_axis(np.array([0.2, -0.3, 1.0]) / np.linalg.norm([0.2, -0.3, 1.0]), 0.7),
                       [40.0, -25.0, 60.0])
    write_fixture_pose(state.project.folder / "fixture_pose.json",
                       FixtureFrame(T, np.eye(6) * 1e-4, "three points", [], np.zeros((0, 3)), np.zeros((0, 3)),
                                    np.zeros((0, 3))))
    world = lab.true_robot.target_position(meas.Q[9], "marker")
    base = page.cell.calibrated.base
    on_fixture = np.linalg.inv(base @ T) @ np.append(world, 1.0)
    assert page.add_point(on_fixture[:3], "fixture")
    wait(page, qtbot)
    fixed = page.points[-1]
    np.testing.assert_allclose(fixed.target, world, atol=1e-6)
    assert page.go_to_point(len(page.points) - 1, nominal=False)
    wait(page, qtbot)
    assert page.points[-1].error_mm() < max(0.3, 5 * fixed.predicted_mm), page.status.text()

    # a program taught with the nominal model, corrected and written
    taught = tmp_path / "taught.csv"
    write_poses(taught, lab.nominal_robot.q_to_file(meas.Q[:5]))
    assert page.load_program(taught)
    wait(page, qtbot)
    assert len(page.points) == 5 and all(q.reachable for q in page.points)
    out = page.write_program(tmp_path / "corrected.csv")
    back = read_poses(out, lab.nominal_robot)
    np.testing.assert_allclose(back.q_file, lab.nominal_robot.q_to_file(np.array([q.q_corrected for q in page.points])),
                               atol=1e-3)
    # the true robot at the corrected joints lands where the nominal model meant the taught joints
    meant = page.cell.nominal.target_positions(meas.Q[:5], "marker")
    assert np.max(np.linalg.norm(lab.true_robot.target_positions(back.Q, "marker") - meant, axis=1)) < 0.3

    # Cartesian targets in the robot base frame, with hint joints, from a targets file
    from core.compensation.targets import write_targets
    base_inv = np.linalg.inv(page.cell.calibrated.base)
    in_base = meant[:3] @ base_inv[:3, :3].T + base_inv[:3, 3]
    targets = write_targets(tmp_path / "targets.csv", ["a", "b", "c"], in_base,
                            hint_file=lab.nominal_robot.q_to_file(meas.Q[:3]))
    assert page.load_program(targets, "base")
    wait(page, qtbot)
    assert [q.name for q in page.points] == ["a", "b", "c"] and all(q.reachable for q in page.points)
    np.testing.assert_allclose([q.target for q in page.points], meant[:3], atol=1e-6)
    landed = lab.true_robot.target_positions(np.array([q.q_corrected for q in page.points]), "marker")
    assert np.max(np.linalg.norm(landed - meant[:3], axis=1)) < 0.3

    # an unreachable point is named and the program is not written over
    assert page.add_point((5000, 0, 0), "base")
    wait(page, qtbot)
    assert not page.points[-1].reachable and "out of reach" in page.points[-1].note
    before = out.read_bytes()
    assert page.write_program(out) is None and "cannot be reached" in page.status.text()
    assert out.read_bytes() == before


@pytest.mark.no_session_cache          # the map must still be under way when it is cancelled
def test_accuracy_map_measured_saved_and_drawn(state, lab, tasks, qtbot, tmp_path):
    calibrate(state, lab)
    page = open_page(qtbot, state, tasks)
    page.map_panel.count_spin.setValue(6)
    # cancelled at the first target: nothing is written
    assert page.measure_map()
    qtbot.waitUntil(lambda: page.task.handle is not None, timeout=TIMEOUT)
    page.task.cancel()
    wait(page, qtbot)
    assert not (state.project.folder / "accuracy_map.json").exists() and not page.is_complete()
    assert page.measure_map()
    wait(page, qtbot)
    amap = page.amap
    assert amap is not None and page.is_complete(), page.status.text()
    assert amap.both.sum() >= 5 and "rendered camera images" in amap.measured_by
    assert amap.rms_before_mm > 1.0 and amap.rms_after_mm < 0.3 and amap.improvement > 10
    saved = read_accuracy_map(state.project.folder / "accuracy_map.json")
    np.testing.assert_allclose(saved.before[amap.both], amap.before[amap.both])
    assert page.map_panel.plot.magnification > 1 and "more accurate" in page.map_panel.summary.text()
    again = open_page(qtbot, state, tasks)            # a new session reads the saved map
    assert again.amap is not None and again.is_complete()
    state.new_project(tmp_path / "other")             # another project: no map drawn, none said
    assert page.amap is None and not page.is_complete()
    assert len(page.map_panel.plot.targets.data) == 0 and "No accuracy map yet" in page.map_panel.summary.text()


@pytest.fixture
def nobody_at_the_screen():
    """The first-motion question is answered yes (app.messages' non-interactive mode)."""
    from app import messages
    messages.set_non_interactive(True)
    yield
    messages.set_non_interactive(False)


def test_over_sim_robot_on_a_pty(state, lab, tasks, qtbot, nobody_at_the_screen):
    """The project's robot is a serial controller (the controller simulator serving the lab's true
    robot on a pty): Go to point and the accuracy map move it, and the lab's cameras render where
    the controller reports its joints."""
    from app.hardware import RobotChoice, open_serial_robot
    from core.robot.controller_sim import ControllerSim

    meas = calibrate(state, lab)
    page = open_page(qtbot, state, tasks)
    with ControllerSim(lab.true_robot, time_scale=0.01) as sim:
        choice = RobotChoice("serial", sim.port)
        state.hardware.use_serial_robot(open_serial_robot(state.robot, choice), choice)
        assert page.on_hardware
        assert page.add_point(lab.true_robot.target_position(meas.Q[7], "marker"), "camera")
        wait(page, qtbot)
        assert page.go_to_point(0)
        wait(page, qtbot)
        point = page.points[0]
        assert point.error_mm() < 0.5, page.status.text()
        assert sim.port in point.measured_by and "rendering the joints it reports" in point.measured_by
        np.testing.assert_allclose(sim.joints(), np.rad2deg(point.q_corrected), atol=2e-3)      # it moved there (deg)
        assert state.hardware.motion_confirmed
        page.map_panel.count_spin.setValue(4)
        assert page.measure_map()
        wait(page, qtbot)
        moves = sum(line.startswith("MOVE") for line in sim.received)
        state.hardware.use_virtual_robot()
    amap = page.amap
    assert amap is not None and amap.both.sum() >= 3, page.status.text()
    assert moves == 1 + 2 * amap.both.sum() and sim.port in amap.measured_by
    assert amap.rms_after_mm < 0.3 and amap.improvement > 10
