"""Each fault the controller simulator injects gives the documented behaviour of the driver
(docs/robot-protocol.md, "Faults"), over real pseudo-terminals."""
from __future__ import annotations

import os
import time

import numpy as np
import pytest

from core.robot.controller_sim import ControllerSim
from core.robot.driver import RobotFault
from core.robot.file import read_robot
from core.robot.model import robot_path
from core.robot.serial_robot import SerialRobot

Q_DEG = [10, -20, 30, 5, 45, -90]


@pytest.fixture
def model():
    return read_robot(robot_path("educational_6r"))


def run_fault(model, faults, protocol="robocal", *, reply_timeout=5.0, move_timeout=20.0, link=None):
    sim = ControllerSim(model, protocol=protocol, faults=faults, time_scale=0.01, link=link).start()
    profile = "robocal_v1" if protocol == "robocal" else "grbl_joint_arm"
    driver = SerialRobot(model, sim.port, profile, reply_timeout=reply_timeout, move_timeout=move_timeout)
    driver.connect()
    return sim, driver


@pytest.mark.parametrize("protocol", ["robocal", "grbl"])
def test_dropped_done_reply_trips_the_watchdog_which_stops_the_robot(model, protocol):
    sim, driver = run_fault(model, "drop@1", protocol, reply_timeout=1.0, move_timeout=1.0)
    try:
        message = {"robocal": r"no done within 1 s; the robot was stopped",
                   "grbl": r"no reply to the move within 1 s"}[protocol]
        with pytest.raises(RobotFault, match=message):
            driver.move_to(model.q_from_file(Q_DEG))
        if protocol == "robocal":
            assert sim.received[-1] == "STOP" and driver.stopped
        assert sim.fired == ["drop@1"]
    finally:
        driver.disconnect()
        sim.close()


@pytest.mark.parametrize("protocol", ["robocal", "grbl"])
def test_garbage_bytes_are_a_fault_never_a_guess(model, protocol):
    sim, driver = run_fault(model, "garbage@1", protocol)
    try:
        with pytest.raises(RobotFault, match=r"unreadable bytes from the controller b'\\x"):
            driver.move_to(model.q_from_file(Q_DEG))
    finally:
        driver.disconnect()
        sim.close()


def test_slow_replies_within_the_reply_timeout_are_waited_for(model):
    sim, driver = run_fault(model, "slow@1:0.3", reply_timeout=5.0)
    try:
        t0 = time.monotonic()
        driver.move_to(model.q_from_file(Q_DEG))
        assert time.monotonic() - t0 >= 0.3 and sim.fired == ["slow@1"]
        np.testing.assert_allclose(sim.joints(), Q_DEG, atol=1e-9)
    finally:
        driver.disconnect()
        sim.close()


def test_slow_replies_past_the_reply_timeout_are_a_fault(model):
    sim, driver = run_fault(model, "slow@1:1.5", reply_timeout=0.3)
    try:
        with pytest.raises(RobotFault, match="no reply to the move within 0.3 s"):
            driver.move_to(model.q_from_file(Q_DEG))
    finally:
        driver.disconnect()
        sim.close()


@pytest.mark.parametrize("protocol, code", [("robocal", "FAULT: motor driver fault on J1"), ("grbl", "ALARM:1")])
def test_fault_mid_move_is_reported_with_the_controllers_words(model, protocol, code):
    sim, driver = run_fault(model, "fault@1", protocol)
    try:
        with pytest.raises(RobotFault, match=f"the controller reported {code}"):
            driver.move_to(model.q_from_file(Q_DEG))
        reached = sim.joints()
        assert 0 < reached[0] < 10 and abs(reached[5]) < 90           # halted half way
    finally:
        driver.disconnect()
        sim.close()


def test_disconnect_after_n_moves_then_reconnect_on_the_same_link(model, tmp_path):
    link = tmp_path / "robot-tty"
    sim, driver = run_fault(model, "disconnect@1", link=link)
    try:
        driver.move_to(model.q_from_file(Q_DEG))                       # move 1 completes
        np.testing.assert_allclose(model.q_to_file(driver.current_joints()), Q_DEG, atol=1e-3)
        old_pty = os.readlink(link)
        with pytest.raises(RobotFault, match="the connection is lost"):   # the line drops at move 2
            driver.move_to(np.zeros(6))
        assert driver.lost
        # while the line is down the link never names the old pty: once the driver lets it go
        # the system may give that name to another program's pty (a parallel test's, in CI)
        assert not os.path.lexists(link) or os.readlink(link) != old_pty
        deadline = time.monotonic() + 10
        while True:
            try:
                driver.connect()
                break
            except RobotFault:
                if time.monotonic() > deadline:
                    raise
                time.sleep(0.05)
        np.testing.assert_allclose(model.q_to_file(driver.current_joints()), Q_DEG, atol=1e-3)
        driver.move_to(np.zeros(6))
        np.testing.assert_allclose(sim.joints(), 0.0, atol=1e-9)
    finally:
        driver.disconnect()
        sim.close()
    assert not os.path.lexists(link)


def test_a_robot_that_stops_short_fails_the_read_back_check(model):
    sim, driver = run_fault(model, "short@1:1")
    try:
        with pytest.raises(RobotFault, match=r"joint J\d is 1.000° from the target \(tolerance 0.05\); "
                                             r"the pose is not measured"):
            driver.move_to(model.q_from_file(Q_DEG))
        driver.move_to(model.q_from_file(Q_DEG))                       # the next move is clean
        np.testing.assert_allclose(sim.joints(), Q_DEG, atol=1e-9)
    finally:
        driver.disconnect()
        sim.close()
