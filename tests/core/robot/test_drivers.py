"""The robot driver interface and the simulated robot (no Qt here)."""
from __future__ import annotations

import threading

import numpy as np
import pytest

from core.errors import RoboCalError
from core.robot.model import robot_path
from core.robot.driver import RobotDriver
from core.robot.simulated import SimulatedRobot
from core.robot.file import read_robot


@pytest.fixture
def model():
    return read_robot(robot_path("educational_6r"))


@pytest.fixture
def robot(model):
    r = SimulatedRobot(model)
    r.connect()
    yield r
    r.disconnect()


def test_simulated_robot_is_a_driver(robot):
    assert isinstance(robot, RobotDriver)
    assert robot.connected and not robot.stopped


def test_move_inside_limits_reaches_the_configuration(robot, model):
    q = model.q_from_file([10, -20, 30, 0, 45, -90])
    robot.move_to(q)
    assert np.allclose(robot.current_joints(), q)
    assert np.allclose(robot.pose(), model.fk(q))
    # returned array is a copy: the caller cannot move the robot by editing it
    robot.current_joints()[0] = 1.0
    assert np.allclose(robot.current_joints(), q)


def test_move_to_the_limit_itself_is_accepted(robot, model):
    lo, hi = model.limits()
    robot.move_to(hi)
    robot.move_to(lo)
    assert np.allclose(robot.current_joints(), lo)


@pytest.mark.parametrize("joint, value_deg", [(0, 151.0), (1, -100.5), (5, 171.0)])
def test_move_outside_limits_is_refused_and_robot_does_not_move(robot, model, joint, value_deg):
    before = robot.current_joints()
    q_deg = np.zeros(6)
    q_deg[joint] = value_deg
    with pytest.raises(RoboCalError) as info:
        robot.move_to(model.q_from_file(q_deg))
    message = info.value.message
    assert f"J{joint + 1}" in message and "outside its limits" in message and "not moved" in message
    assert f"{value_deg:.3f}" in message
    assert np.array_equal(robot.current_joints(), before)
    assert robot.move_count == 0


@pytest.mark.parametrize("q", [np.zeros(5), np.zeros(7), [0, 0, np.nan, 0, 0, 0], "abc"])
def test_bad_joint_vectors_are_refused(robot, q):
    with pytest.raises(RoboCalError):
        robot.move_to(q)


def test_not_connected_refuses_motion(model):
    robot = SimulatedRobot(model)
    with pytest.raises(RoboCalError, match="not connected"):
        robot.move_to(np.zeros(6))


def test_stop_latches_until_resume(robot):
    robot.stop()
    assert robot.stopped and robot.stop_count == 1
    with pytest.raises(RoboCalError, match="stopped"):
        robot.move_to(np.full(6, 0.1))
    robot.resume()
    robot.move_to(np.full(6, 0.1))
    assert np.allclose(robot.current_joints(), 0.1)


class _SlowRobot(SimulatedRobot):
    """A simulated robot whose move is held inside `_move` until `release` is set."""

    def __init__(self, model):
        super().__init__(model)
        self.entered, self.release = threading.Event(), threading.Event()

    def _move(self, q):
        self.entered.set()
        assert self.release.wait(10)
        super()._move(q)


def test_stop_during_a_move_returns_after_it_and_no_move_follows(model):
    """A stop from another thread while a move is being sent: stop() returns only once that
    move is done, and the worker's next move is refused (no check-then-move gap)."""
    robot = _SlowRobot(model)
    robot.connect()
    worker = threading.Thread(target=robot.move_to, args=(np.full(6, 0.1),))
    worker.start()
    assert robot.entered.wait(10)
    stopper = threading.Thread(target=robot.stop)
    stopper.start()
    stopper.join(0.2)
    assert stopper.is_alive() and robot.stop_count == 1          # the halt went out at once
    robot.release.set()
    worker.join(10)
    stopper.join(10)
    assert not stopper.is_alive() and robot.stopped and robot.move_count == 1
    with pytest.raises(RoboCalError, match="stopped"):
        robot.move_to(np.full(6, 0.2))
    assert robot.move_count == 1 and np.allclose(robot.current_joints(), 0.1)


def test_stop_is_always_safe(model):
    robot = SimulatedRobot(model)
    robot.stop()            # not connected: still fine
    robot.stop()            # twice: still fine
    assert robot.stop_count == 2


def test_context_manager_connects_and_always_disconnects(model):
    robot = SimulatedRobot(model)
    with pytest.raises(RuntimeError):
        with robot:
            assert robot.connected
            raise RuntimeError("boom")
    assert not robot.connected and robot.stopped


def test_start_configuration_is_inside_limits(model):
    # a model whose zero configuration lies outside a joint's limits starts clipped
    shifted = model.copy()
    shifted.joints[1].min, shifted.joints[1].max = 0.2, 1.0
    robot = SimulatedRobot(shifted)
    assert bool(shifted.within_limits(robot.current_joints()))
    with pytest.raises(RoboCalError):
        SimulatedRobot(shifted, q0=np.zeros(6))
