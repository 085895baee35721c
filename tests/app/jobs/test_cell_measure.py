"""Drive, capture, locate on a connected cell (app.jobs.cell_measure.CellMeasure), as the Check page
and `robocal check --port` run it: the controller simulator on a real pseudo-terminal, the virtual
lab's cameras writing what they see of the simulator's robot to two image folders after every
motion (read with the camera code the Setup page opens).

The robot moves on to the next planned pose while the marker is located, without mixing up the
pairs; a fault of a move made ahead (or the watchdog's timeout) ends the run with the points
measured kept — the page reads `fault`, the command line raises it; after a cancel no move is
started ahead; a pose outside the limits is refused before the robot is connected."""
from __future__ import annotations

import time

import numpy as np
import pytest

from app.hardware import CameraChoice, LiveCameras, RobotChoice, open_serial_robot
from app.jobs import check_sources
from app.jobs.cell_check import check_cell, setup_cell
from app.jobs.cell_measure import CellMeasure, cell_options, locator
from app.lab import build_lab, ideal_lab_measurements, write_ideal_measurements
from app.sim_cameras import SimulatedCellCameras
from core.errors import RoboCalError
from core.identification.file import write_calibrated_model
from core.identification.solver import identify
from core.monitoring.log import read_check_log
from core.robot.controller_sim import ControllerSim
from core.robot.driver import RobotFault
from core.stereo.rectification import load_rectification
from tests.app.virtual_inputs import lab_marker, true_stereo_yaml

POSES = 5


@pytest.fixture(scope="module")
def lab_cell(tmp_path_factory):
    """The lab, its check of POSES poses chosen for its calibrated cameras, the stereo calibration
    and the trained marker."""
    folder = tmp_path_factory.mktemp("cellmeasure")
    lab = build_lab(None, 0, 0.5)
    meas = ideal_lab_measurements(lab, 50, sigma_mm=0.05, seed=4)
    write_ideal_measurements(meas, folder / "measurements.csv", sigma_mm=0.05)
    write_calibrated_model(identify(lab.nominal_robot, meas), folder / "calibrated.json")
    rect = load_rectification(true_stereo_yaml(lab, folder / "stereo.yaml"))
    check = setup_cell(folder / "calibrated.json", cell_options(rect.calibration.rig, folder / "measurements.csv"),
                       count=POSES)
    return lab, check, rect, lab_marker(lab)


class Connected:
    """The simulator (faults `faults`, watchdog `move_timeout` s), its cameras and the driver."""

    def __init__(self, lab, folder, faults="", move_timeout=60.0):
        self.cameras = SimulatedCellCameras(lab, folder)
        self.sim = ControllerSim(lab.true_robot, faults=faults, time_scale=0.01,
                                 on_rest=self.cameras.on_rest).start()
        self.live = LiveCameras.open(CameraChoice("sources", str(self.cameras.left), str(self.cameras.right)))
        self.driver = open_serial_robot(lab.nominal_robot, RobotChoice("serial", self.sim.port, "robocal_v1"),
                                        reply_timeout=10.0, move_timeout=move_timeout)

    def close(self):
        self.driver.disconnect()
        self.live.close()
        self.sim.close()


class NextMoveWatch:
    """The marker locator, which first waits (up to 10 s) for the controller to accept the next
    planned move, and records whether it did while this pair was being located."""

    def __init__(self, locator, sim, poses):
        self.locator, self.sim, self.poses = locator, sim, poses
        self.overlapped = []

    def locate(self, left, right):
        located = len(self.overlapped) + 1                   # this pair is of pose `located` (from 1)
        if located < self.poses:                             # the last pose has no next one
            deadline = time.monotonic() + 10.0
            while self.sim.moves <= located and time.monotonic() < deadline:
                time.sleep(0.01)
            self.overlapped.append(self.sim.moves == located + 1)
        return self.locator.locate(left, right)


def test_the_robot_moves_on_while_the_marker_is_located(lab_cell, tmp_path):
    lab, check, rect, trained = lab_cell
    cell = Connected(lab, tmp_path / "cams")
    try:
        watch = NextMoveWatch(locator(trained, rect), cell.sim, POSES)
        measure = CellMeasure(cell.driver, cell.live, watch, plan=check.Q)
        result, diagnosis = check_cell(check, measure, log=tmp_path / "c.csv")
        moves = cell.sim.moves
    finally:
        cell.close()
    assert watch.overlapped == [True] * (POSES - 1)       # each next move accepted while a pair was located
    assert moves == measure.moves == POSES and measure.fault is None
    assert len(result.points) == POSES and result.within and diagnosis is None, result.verdict()
    for p in result.points:                                # each pair located is the pair of its own pose
        truth = lab.true_robot.target_position(p.Q, lab.target)
        assert np.linalg.norm(p.measured - truth) < 0.2
    np.testing.assert_allclose(measure.reached, check.Q, atol=1e-4)


def test_a_fault_of_a_move_made_ahead_ends_the_run_with_the_points_kept(lab_cell, tmp_path):
    """The third move (started while the second pair was located) faults: the page's run ends
    through its cancel check with two points; the command line raises the fault."""
    lab, check, rect, trained = lab_cell
    cell = Connected(lab, tmp_path / "cams", faults="fault@3")
    try:
        measure = CellMeasure(cell.driver, cell.live, locator(trained, rect), plan=check.Q)
        result, diagnosis = check_cell(check, measure, log=tmp_path / "c.csv")
        moves, stopped = cell.sim.moves, cell.driver.stopped
    finally:
        cell.close()
    assert cell.sim.fired == ["fault@3"] and moves == 3 and stopped
    assert result.cancelled and [p.pose for p in result.points] == [0, 1] and diagnosis is None
    assert "FAULT" in measure.fault
    logged = read_check_log(tmp_path / "c.csv").checks
    assert len(logged) == 1 and not logged[0].finished and len(logged[0].points) == 2
    poses = check_sources.MeasuredPoses(check.Q, np.arange(POSES), measure, "the cell", cell=measure)
    with pytest.raises(RobotFault, match="robot fault, the run stopped there .*FAULT"):
        poses.raise_fault()


def test_a_watchdog_timeout_is_a_fault_not_the_stop_key(lab_cell, tmp_path):
    """The second move's done reply never comes: the driver's watchdog stops the robot, which is
    a fault with its reason (not the Stop key, though the robot is stopped all the same)."""
    lab, check, rect, trained = lab_cell
    cell = Connected(lab, tmp_path / "cams", faults="drop@2", move_timeout=2.0)
    try:
        measure = CellMeasure(cell.driver, cell.live, locator(trained, rect), plan=check.Q)
        result, _ = check_cell(check, measure)
    finally:
        cell.close()
    assert result.cancelled and len(result.points) == 1
    assert measure.fault is not None and "no done within 2 s" in measure.fault


def test_after_a_cancel_no_move_is_started_ahead(lab_cell, tmp_path):
    lab, check, rect, trained = lab_cell
    cell = Connected(lab, tmp_path / "cams")
    try:
        measure = CellMeasure(cell.driver, cell.live, locator(trained, rect), plan=check.Q)
        result, _ = check_cell(check, measure, cancelled=lambda: measure.moves >= 2)
        moves = cell.sim.moves
    finally:
        cell.close()
    assert moves == 2 and result.cancelled and len(result.points) == 2 and measure.fault is None


def test_a_pose_outside_the_limits_is_refused_before_the_robot_is_connected(lab_cell, tmp_path):
    lab, check, rect, trained = lab_cell
    Q = np.array(check.Q)
    Q[2, 1] = lab.nominal_robot.limits()[1][1] + np.deg2rad(5.0)
    cameras = SimulatedCellCameras(lab, tmp_path / "cams")
    with ControllerSim(lab.true_robot, time_scale=0.01, on_rest=cameras.on_rest) as sim:
        with pytest.raises(RoboCalError, match="pose 2: joint .* is outside its limits"):
            check_sources.connected_cell(lab.nominal_robot, Q, sim.port, "robocal_v1",
                                         (str(cameras.left), str(cameras.right)), locator(trained, rect))
        assert sim.moves == 0


def test_the_command_line_cell_raises_a_fault_instead_of_measuring_on(lab_cell, tmp_path):
    """The cell as `robocal identify-tool --port` opens it: a fault of the second move ends the
    measurements with the RobotFault (exit 1), not with the one pose measured before it."""
    lab, check, rect, trained = lab_cell
    cameras = SimulatedCellCameras(lab, tmp_path / "cams")
    with ControllerSim(lab.true_robot, faults="fault@2", time_scale=0.01, on_rest=cameras.on_rest) as sim:
        poses = check_sources.connected_cell(lab.nominal_robot, check.Q, sim.port, "robocal_v1",
                                             (str(cameras.left), str(cameras.right)), locator(trained, rect))
        with pytest.raises(RobotFault, match="robot fault, the run stopped there .*FAULT"):
            with poses:
                poses.measurements(lab.nominal_robot)
        moves = sim.moves
    assert moves == 2 and poses.cell.driver.stopped and poses.cell.moves == 1
    assert poses.where == f"serial robot on {sim.port} (RoboCal serial protocol v1), cameras {cameras.left}, " \
                          f"{cameras.right}"
