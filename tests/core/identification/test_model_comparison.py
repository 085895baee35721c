"""core.identification.model_comparison: distances between two models' targets over configurations."""
from __future__ import annotations

import math

import numpy as np
import pytest

from core import transforms as tf
from core.errors import RoboCalError
from core.kinematics.identifiability import random_configurations
from core.identification.solver import identify
from core.robot.model import robot_path
from core.identification.model_comparison import (accuracy_against_truth, common_targets, compare_models,
                                                  identification_accuracy)
from core.robot.file import read_robot
from core.virtual_lab.synthetic import perturbed_model, simulate_measurements


@pytest.fixture(scope="module")
def robot():
    return read_robot(robot_path("educational_6r"))


def test_identical_models_have_zero_error(robot):
    Q = random_configurations(robot, 20, seed=1)
    c = compare_models(robot, robot.copy(), Q)
    assert c.n == 20 and c.n_configurations == 20 and c.targets == ["marker"]
    assert c.max_mm == 0.0 and c.rms_mm == 0.0


def test_a_shifted_base_gives_exactly_the_shift(robot):
    moved = robot.copy()
    moved.base = tf.make_transform(None, [3.0, 4.0, 0.0]) @ robot.base      # 5 mm everywhere
    c = compare_models(robot, moved, random_configurations(robot, 15, seed=2))
    assert c.mean_mm == pytest.approx(5.0) and c.rms_mm == pytest.approx(5.0)
    assert c.max_mm == pytest.approx(5.0) and c.median_mm == pytest.approx(5.0)
    assert c.summary()["rms_mm"] == pytest.approx(5.0)


def test_alignment_removes_a_frame_offset_but_not_a_geometry_error(robot):
    Q = random_configurations(robot, 40, seed=3)
    moved = robot.copy()                                   # the same robot in a tilted frame
    moved.base = tf.pose_to_matrix([2.0, -1.0, 0.5], np.deg2rad([0.05, -0.03, 0.04])) @ robot.base
    c = compare_models(robot, moved, Q, align=True)
    assert c.aligned and c.rms_mm < 1e-9 and c.raw_rms_mm > 2.0
    bent = moved.copy()
    bent.joints[2].a += 0.5                                # a real geometric error stays visible
    c = compare_models(robot, bent, Q, align=True)
    assert 0.05 < c.rms_mm < 0.5 and c.raw_rms_mm > c.rms_mm


def test_statistics_match_a_direct_computation(robot):
    other = perturbed_model(robot, 3, base_xyz=(0, 0, 0), base_rpy_deg=(0, 0, 0))
    other.targets["tip"] = np.array([0.0, 10.0, 40.0])
    ref = robot.copy()
    ref.targets["tip"] = np.array([0.0, 10.0, 41.0])
    Q = random_configurations(robot, 30, seed=4)
    c = compare_models(ref, other, Q)
    assert c.targets == ["marker", "tip"] and c.n == 60
    d = np.concatenate([other.target_positions(Q, t)[:, None] - ref.target_positions(Q, t)[:, None]
                        for t in ("marker", "tip")], axis=1).reshape(-1, 3)
    e = np.linalg.norm(d, axis=1)
    assert np.allclose(c.errors, e)
    assert c.rms_mm == pytest.approx(math.sqrt(np.mean(e ** 2)))
    assert c.max_mm == pytest.approx(e.max()) and c.mean_mm == pytest.approx(e.mean())
    only = compare_models(ref, other, Q, targets=["tip"])
    assert only.n == 30 and np.allclose(only.errors, e[1::2])


def test_a_single_configuration_is_accepted(robot):
    c = compare_models(robot, robot, np.zeros(robot.dof))
    assert c.n == 1 and c.n_configurations == 1


@pytest.mark.parametrize("change, message", [
    ("dof", "different joint counts"),
    ("no_target", "share no target"),
    ("missing_target", "target 'tip' is not defined"),
    ("bad_q", "expected 6 joint values"),
])
def test_bad_input_is_a_clear_error(robot, change, message):
    other = robot.copy()
    Q = np.zeros((3, robot.dof))
    targets = None
    if change == "dof":
        other.joints = other.joints[:5]
    elif change == "no_target":
        other.targets = {"tip": np.zeros(3)}
    elif change == "missing_target":
        targets = ["tip"]
    elif change == "bad_q":
        Q = np.zeros((3, 4))
    with pytest.raises(RoboCalError, match=message):
        compare_models(robot, other, Q, targets)
    assert common_targets(robot, robot) == ["marker"]


def test_calibration_brings_the_model_close_to_the_truth(robot):
    true = perturbed_model(robot, 7)
    meas = simulate_measurements(true, 40, sigma_mm=0.05, rng=8)
    result = identify(robot, meas)
    Q = random_configurations(robot, 100, seed=9)
    acc = accuracy_against_truth(true, result.initial, result.model, Q)
    assert acc.n_configurations == 100
    assert acc.nominal.rms_mm > 1.0                 # millimetres off before
    assert acc.calibrated.rms_mm < 0.1              # close to the truth after
    assert acc.improvement > 10
    assert set(acc.summary()) == {"n_configurations", "nominal", "calibrated"}


def test_an_identification_judged_against_the_truth(robot):
    true = perturbed_model(robot, 7)
    result = identify(robot, simulate_measurements(true, 40, sigma_mm=0.05, rng=8))
    Q = random_configurations(robot, 50, seed=10)
    acc = identification_accuracy(true, result, Q, ["marker"])
    assert acc.n_configurations == 50 and acc.calibrated.targets == ["marker"]
    assert acc.nominal.aligned and acc.calibrated.aligned
    assert acc.nominal.rms_mm > 1.0 and acc.calibrated.rms_mm < 0.1
    # the nominal side has its base registered: far nearer the truth than the unregistered model
    assert acc.nominal.raw_rms_mm < compare_models(true, robot, Q).rms_mm
