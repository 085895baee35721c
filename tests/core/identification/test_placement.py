"""Placing a once-measured target on the tool: relative to calibrated targets, or from the model."""
from __future__ import annotations

import numpy as np
import pytest

from core import transforms as tf
from core.errors import RoboCalError
from core.identification.placement import place_targets
from core.measurement.file import Measurements
from core.robot.file import read_robot
from core.robot.model import robot_path


@pytest.fixture
def robot():
    model = read_robot(robot_path("abb_irb120"))
    model.targets = {"p1": np.array([0.0, 16.0, 20.0]), "p2": np.array([0.0, 5.0, 35.0])}
    return model


def once(model, q_deg, new=np.array([1.0, 17.0, 21.0])):
    """The true `model` with a new target `t1` measured at q together with p1 and p2."""
    true = model.copy()
    true.targets["t1"] = new
    q = np.deg2rad(q_deg)
    xyz = [true.target_position(q, t) for t in ("t1", "p1", "p2")]
    return Measurements(pose=np.array([7, 7, 7]), target=["t1", "p1", "p2"], q_file=np.tile(q_deg, (3, 1)),
                        xyz=np.array(xyz))


def test_relative_placement_cancels_the_model_s_position_error(robot):
    meas = once(robot, np.array([10.0, -20.0, 15.0, 30.0, 40.0, -50.0]))
    wrong = robot.copy()
    wrong.base = tf.make_transform(None, [0.4, -0.3, 0.2]) @ robot.base      # the model is 0.54 mm off
    relative, placed = place_targets(wrong, meas, references=["p1"])
    np.testing.assert_allclose(relative.targets["t1"], [1.0, 17.0, 21.0], atol=1e-9)
    assert placed[0].references == ["p1"] and placed[0].poses == [7] and placed[0].how == "relative to p1"
    absolute, placed = place_targets(wrong, meas, names=["t1"])
    assert np.linalg.norm(absolute.targets["t1"] - [1.0, 17.0, 21.0]) == pytest.approx(0.5385, abs=1e-3)
    assert placed[0].how == "from the model alone"
    both, placed = place_targets(wrong, meas, references=["p1", "p2"])
    np.testing.assert_allclose(both.targets["t1"], [1.0, 17.0, 21.0], atol=1e-9)
    assert placed[0].spread_mm < 1e-9 and "t1" not in robot.targets


def test_an_orientation_error_is_scaled_by_the_distance_to_the_reference(robot):
    meas = once(robot, np.zeros(6))
    turned = robot.copy()
    turned.joints[5].theta += np.deg2rad(0.1)          # the last joint's zero off by 0.1°
    near, _ = place_targets(turned, meas, references=["p1"])          # t1 − p1 = (1, 1, 1) mm
    far, _ = place_targets(turned, meas, references=["p2"])           # t1 − p2 = (1, 12, −14) mm
    e_near = np.linalg.norm(near.targets["t1"] - [1.0, 17.0, 21.0])
    e_far = np.linalg.norm(far.targets["t1"] - [1.0, 17.0, 21.0])
    # the turn about the tool z axis moves the difference by its length across that axis × 0.1°
    assert e_near == pytest.approx(np.deg2rad(0.1) * np.sqrt(2.0), rel=1e-3)
    assert e_far == pytest.approx(np.deg2rad(0.1) * np.sqrt(145.0), rel=1e-3)


def test_refusals_name_the_pose_and_the_target(robot):
    meas = once(robot, np.zeros(6))
    only_t1 = Measurements(pose=np.array([7]), target=["t1"], q_file=np.zeros((1, 6)), xyz=meas.xyz[:1],
                           source="once.csv")
    with pytest.raises(RoboCalError, match="pose 7 measures 't1' but not the reference 'p1'") as err:
        place_targets(robot, only_t1, references=["p1"])
    assert err.value.source == "once.csv"
    moved = Measurements(pose=np.array([7, 7]), target=["t1", "p1"], q_file=np.array([np.zeros(6), np.ones(6)]),
                         xyz=meas.xyz[:2])
    with pytest.raises(RoboCalError, match="different joint values"):
        place_targets(robot, moved, references=["p1"])
    with pytest.raises(RoboCalError, match="reference target 'p9' is not in the robot"):
        place_targets(robot, meas, references=["p9"])
    reference_only = Measurements(pose=np.array([7]), target=["p1"], q_file=np.zeros((1, 6)), xyz=meas.xyz[1:2])
    with pytest.raises(RoboCalError, match="no target to place"):
        place_targets(robot, reference_only)
