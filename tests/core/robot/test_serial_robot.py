"""The serial driver against the controller simulator on real pseudo-terminals, for both
protocols: every command, the limits check before writing, stop, joint maps, settle rule."""
from __future__ import annotations

import os
import select
import threading
import time
import tty
from dataclasses import replace

import numpy as np
import pytest

from core.errors import RoboCalError
from core.robot.controller_sim import ControllerSim, FaultPlan
from core.robot.driver import RobotDriver
from core.robot.file import read_robot
from core.robot.joint_map import JointMap
from core.robot.model import robot_path
from core.robot.profile import SettleRule, builtin_profile
from core.robot.serial_robot import RobotStopped, SerialRobot

PROFILES = {"robocal": "robocal_v1", "grbl": "grbl_joint_arm"}
Q_DEG = [10, -20, 30, 5, 45, -90]


@pytest.fixture
def model():
    return read_robot(robot_path("educational_6r"))


def connect(model, sim, profile, **kw):
    options = dict(reply_timeout=5.0, move_timeout=20.0)
    options.update(kw)
    driver = SerialRobot(model, sim.port, profile, **options)
    driver.connect()
    return driver


@pytest.mark.parametrize("protocol", ["robocal", "grbl"])
def test_every_command_over_a_pty(model, protocol):
    with ControllerSim(model, protocol=protocol, time_scale=0.01) as sim:
        driver = connect(model, sim, PROFILES[protocol], speed=50)
        try:
            assert isinstance(driver, RobotDriver) and driver.connected
            info = driver.info
            assert info.dof == 6 and info.units == "deg" and info.can_move and info.has_stop
            assert info.reports_motion_state
            if protocol == "robocal":
                assert info.name == "Educational_6R_arm_(Robix_RCS-6_style)"
            np.testing.assert_allclose(driver.current_joints(), 0.0, atol=1e-9)
            q = model.q_from_file(Q_DEG)
            driver.move_to(q)                                   # returns once settled
            np.testing.assert_allclose(model.q_to_file(driver.current_joints()), Q_DEG, atol=1e-3)
            np.testing.assert_allclose(sim.joints(), Q_DEG, atol=1e-9)
            driver.set_speed(100)
            deadline = time.monotonic() + 5
            while sim.speed != 100.0 and time.monotonic() < deadline:    # GRBL: a real-time byte, no reply
                time.sleep(0.01)
            assert sim.speed == 100.0 and driver.speed == 100.0
            driver.stop()
            assert driver.stopped
            with pytest.raises(RoboCalError, match="stopped"):
                driver.move_to(np.zeros(6))
            driver.resume()
            driver.move_to(np.zeros(6))
            np.testing.assert_allclose(sim.joints(), 0.0, atol=1e-9)
        finally:
            driver.disconnect()
    assert not driver.connected
    if protocol == "robocal":
        assert sim.received[:2] == ["HELLO", "SPEED 50"]
        assert sim.received[3] == "MOVE 10.0000 -20.0000 30.0000 5.0000 45.0000 -90.0000"
        assert "STOP" in sim.received
    else:
        assert "G90 G0 X10.000 Y-20.000 Z30.000 A5.000 B45.000 C-90.000" in sim.received
        assert "$X" in sim.received                        # resume unlocks


@pytest.mark.parametrize("protocol", ["robocal", "grbl"])
def test_stop_during_a_move_halts_it_and_no_done_follows(model, protocol):
    with ControllerSim(model, protocol=protocol, time_scale=1.0, joint_speed=20.0) as sim:   # 4.5 s move
        driver = connect(model, sim, PROFILES[protocol], speed=100)
        errors = []

        def move():
            try:
                driver.move_to(model.q_from_file([90, 0, 0, 0, 0, 0]))
            except RoboCalError as exc:
                errors.append(exc)

        worker = threading.Thread(target=move)
        worker.start()
        deadline = time.monotonic() + 5
        while sim.joints()[0] < 1.0 and time.monotonic() < deadline:
            time.sleep(0.01)
        driver.stop()
        worker.join(10)
        assert not worker.is_alive() and len(errors) == 1 and isinstance(errors[0], RobotStopped)
        halted = sim.joints()[0]
        assert 0.5 < halted < 90.0
        time.sleep(0.1)
        assert sim.joints()[0] == halted                      # it stays where it stopped
        driver.disconnect()


def raw_pty():
    master, slave = os.openpty()
    tty.setraw(slave)
    return master, slave, os.ttyname(slave)


def test_a_move_outside_the_limits_is_refused_before_anything_is_written(model):
    master, slave, name = raw_pty()
    seen = bytearray()
    done = threading.Event()

    def controller():                     # a minimal v1 controller that records every byte
        buf = b""
        while not done.is_set():
            if not select.select([master], [], [], 0.02)[0]:
                continue
            data = os.read(master, 1024)
            seen.extend(data)
            buf += data
            while b"\n" in buf:
                line, buf = buf.split(b"\n", 1)
                reply = {b"HELLO": b"ROBOCAL 1 test 6\n", b"POS?": b"POS 0 0 0 0 0 0\n"}.get(line, b"OK\n")
                os.write(master, reply)

    thread = threading.Thread(target=controller, daemon=True)
    thread.start()
    driver = SerialRobot(model, name, "robocal_v1", reply_timeout=5.0)
    try:
        driver.connect()
        assert bytes(seen) == b"HELLO\nSPEED 25\n"          # default speed for a real robot: 25 %
        with pytest.raises(RoboCalError, match="J2: 120.000° is outside its limits.*not moved"):
            driver.move_to(model.q_from_file([0, 120, 0, 0, 0, 0]))
        time.sleep(0.2)
        assert bytes(seen) == b"HELLO\nSPEED 25\n"          # nothing was written for the refused move
    finally:
        driver.disconnect()
        done.set()
        thread.join(2)
        os.close(master)
        os.close(slave)


def test_limit_error_from_the_controller_is_reported(model):
    narrow = model.copy()
    narrow.joints[0].max = np.deg2rad(5.0)               # the controller's limits are tighter
    with ControllerSim(narrow, time_scale=0.01) as sim:
        driver = connect(model, sim, "robocal_v1")
        with pytest.raises(RoboCalError, match=r"reported LIMIT: J1 10.000 outside \[-150.000, 5.000\]"):
            driver.move_to(model.q_from_file(Q_DEG))
        driver.disconnect()


def test_joint_map_sign_offset_and_ticks(model):
    rev = model.revolute_mask()
    jm = JointMap(rev, units="ticks", sign=[1, -1, 1, 1, 1, 1], offset=[0, 90, 0, 0, 0, 0], ticks_per_unit=10)
    q = model.q_from_file(Q_DEG)
    ctrl = jm.to_controller(q)
    np.testing.assert_allclose(ctrl, [100, -(-200 + 90), 300, 50, 450, -900])
    np.testing.assert_allclose(jm.from_controller(ctrl), q, atol=1e-12)
    np.testing.assert_allclose(JointMap(rev, units="rad").to_controller(q), q)
    with pytest.raises(RoboCalError, match="ticks_per_unit"):
        JointMap(rev, units="ticks")
    with pytest.raises(RoboCalError, match="sign"):
        JointMap(rev, sign=[2, 1, 1, 1, 1, 1])


def test_driver_with_a_joint_map_talks_controller_units(model):
    with ControllerSim(model, time_scale=0.01) as sim:
        driver = connect(model, sim, "robocal_v1", joint_map={"units": "deg", "sign": [-1, 1, 1, 1, 1, 1],
                                                                "offset": [2, 0, 0, 0, 0, 0]})
        driver.move_to(model.q_from_file(Q_DEG))
        np.testing.assert_allclose(sim.joints(), [-12, -20, 30, 5, 45, -90], atol=1e-9)
        np.testing.assert_allclose(model.q_to_file(driver.current_joints()), Q_DEG, atol=1e-3)
        driver.disconnect()


def test_a_controller_without_done_is_watched_until_still(model):
    profile = builtin_profile("robocal_v1")
    profile = replace(profile, done_reply=None, settle=SettleRule(tolerance=1e-3, dwell_s=0.15, timeout_s=20))
    with ControllerSim(model, time_scale=0.02, report_done=False) as sim:
        driver = connect(model, sim, profile)
        assert not driver.info.reports_motion_state
        driver.move_to(model.q_from_file(Q_DEG))
        np.testing.assert_allclose(sim.joints(), Q_DEG, atol=1e-9)       # settled means arrived
        assert "DONE" not in sim.received
        driver.disconnect()


def test_wrong_joint_count_and_no_controller(model, tmp_path):
    small = model.copy()
    small.joints = small.joints[:5]
    with ControllerSim(small, time_scale=0.01) as sim:
        with pytest.raises(RoboCalError, match="the controller has 5 joints, the robot model 6"):
            SerialRobot(model, sim.port, reply_timeout=5.0).connect()
    with pytest.raises(RoboCalError, match="cannot open the port"):
        SerialRobot(model, str(tmp_path / "no-such-tty")).connect()
    master, slave, name = raw_pty()                       # a device that never answers
    try:
        with pytest.raises(RoboCalError, match="no reply to the identification within 0.3 s"):
            SerialRobot(model, name, reply_timeout=0.3).connect()
    finally:
        os.close(master)
        os.close(slave)


def test_fault_spec_parsing():
    plan = FaultPlan.parse("drop@3, slow@2:1.5,short~0.5")
    assert plan.at == {3: {"drop": 0.0}, 2: {"slow": 1.5}} and plan.chance == {"short": (0.5, 1.0)}
    for bad in ("melt@2", "drop@0", "drop~2", "drop"):
        with pytest.raises(RoboCalError):
            FaultPlan.parse(bad)
