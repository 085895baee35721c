"""The measurement run over the serial driver and the controller simulator (a real pty):
a disconnect stops the run, keeps what was measured, and the resumed run measures every
pose exactly once; a robot that stops short is never measured at that pose."""
from __future__ import annotations

import time

import numpy as np
import pytest

from core.measurement.capture import RenderedSource
from core.measurement.file import read_measurements
from core.measurement.run import poses_from_internal, read_rejects, rejects_path_for, run_measurements
from core.robot.controller_sim import ControllerSim
from core.robot.driver import RobotFault
from core.robot.file import read_robot
from core.robot.model import robot_path
from core.robot.serial_robot import SerialRobot

from tests.core.measurement.test_run import fake_locate


@pytest.fixture
def model():
    return read_robot(robot_path("educational_6r"))


def pose_list(model, n=8):
    q = np.round(np.random.default_rng(3).uniform(5, 40, (n, 6)), 3)
    return poses_from_internal(model.q_from_file(q), model, ids=np.arange(100, 100 + n))


def joints_source(driver):
    """A 'camera' whose images are the joint values the robot reports (fake_locate reads them)."""
    def render():
        q = driver.model.q_to_file(driver.current_joints())
        return q, q
    return RenderedSource(render)


def reconnect(driver, timeout=10.0):
    deadline = time.monotonic() + timeout
    while True:
        try:
            driver.connect()
            driver.resume()
            return
        except RobotFault:
            if time.monotonic() > deadline:
                raise
            time.sleep(0.05)


def test_a_run_interrupted_by_a_disconnect_resumes_and_measures_every_pose_once(model, tmp_path):
    link = tmp_path / "robot-tty"
    out = tmp_path / "meas.csv"
    poses = pose_list(model)
    with ControllerSim(model, faults="disconnect@3", time_scale=0.01, link=link) as sim:
        driver = SerialRobot(model, str(link), reply_timeout=5.0, move_timeout=20.0)
        driver.connect()
        first = run_measurements(poses, out, locate=fake_locate, source=joints_source(driver), driver=driver)
        assert first.fault is not None and "the connection is lost" in first.fault
        assert "\n" not in first.fault
        assert [o.pose for o in first.measured] == [100, 101, 102] and not first.rejected
        assert first.remaining == 5 and driver.stopped
        assert list(read_measurements(out).pose) == [100, 101, 102]
        reconnect(driver)
        second = run_measurements(poses, out, locate=fake_locate, source=joints_source(driver), driver=driver)
        driver.disconnect()
    assert second.fault is None and len(second.skipped) == 3 and len(second.measured) == 5
    meas = read_measurements(out)
    assert list(meas.pose) == list(range(100, 108))                        # every pose exactly once
    np.testing.assert_allclose(meas.q_file, poses.q_file, atol=1e-3)
    np.testing.assert_allclose(meas.xyz, 10.0 * poses.q_file[:, :3] + [0, 0, 600.0], atol=1e-2)
    assert sim.moves == 8 and sim.fired == ["disconnect@3"]
    assert all(o.grab_gap == 0.0 for o in second.measured)


@pytest.mark.parametrize("faults, words", [("short@2:1", "is 1.000° from the target"),
                                           ("fault@2", "reported FAULT"),
                                           ("garbage@2", "unreadable bytes")])
def test_a_fault_at_a_pose_writes_nothing_for_it_and_the_resumed_run_measures_it(model, tmp_path, faults, words):
    out = tmp_path / "meas.csv"
    poses = pose_list(model, 4)
    with ControllerSim(model, faults=faults, time_scale=0.01) as sim:
        driver = SerialRobot(model, sim.port, reply_timeout=5.0, move_timeout=20.0)
        driver.connect()
        first = run_measurements(poses, out, locate=fake_locate, source=joints_source(driver), driver=driver)
        assert words in first.fault and [o.pose for o in first.outcomes] == [100]
        assert list(read_measurements(out).pose) == [100] and read_rejects(rejects_path_for(out)) == {}
        assert "STOP" in sim.received                                      # the run stopped the robot
        reconnect(driver)
        second = run_measurements(poses, out, locate=fake_locate, source=joints_source(driver), driver=driver)
        driver.disconnect()
    assert second.fault is None and list(read_measurements(out).pose) == [100, 101, 102, 103]
