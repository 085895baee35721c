"""Identification with measured marker orientations: the orientation rows, and what they determine."""
from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from core import transforms as tf
from core.errors import RoboCalError
from core.kinematics.jacobian import all_parameters, apply_step
from core.identification.orientation import require_orientations, with_measured_rotations
from core.kinematics.orientation import orientation_jacobian, predict_rotations
from core.identification.solver import identify
from core.measurement.file import Measurements
from core.robot.file import read_robot
from core.robot.model import robot_path
from core.virtual_lab.synthetic import perturbed_model, simulate_measurements

SIGMA_MM, SIGMA_DEG = 0.02, 0.02


@pytest.fixture(scope="module")
def nominal():
    robot = read_robot(robot_path("educational_6r"))
    robot.targets = {"marker": np.array([0.0, 0.0, 25.0])}        # on the last joint's axis
    return robot


@pytest.fixture(scope="module")
def true(nominal):
    return perturbed_model(nominal, 3, target_mm=0.0)             # the marker stays on the axis


@pytest.fixture(scope="module")
def meas(true):
    return simulate_measurements(true, 40, sigma_mm=SIGMA_MM, rng=4, with_sigma=True,
                                 orientation_sigma_deg=SIGMA_DEG)


def test_orientation_rows_are_the_derivative_of_the_predicted_frame(nominal, true):
    model = true.copy()
    model.target_rotations["marker"] = tf.rot_vec([0.1, -0.2, 0.3])
    model.joints[1].beta = 0.01
    Q = np.random.default_rng(0).uniform(-1.5, 1.5, (5, 6))
    names = ["marker"] * 5
    params = all_parameters(model, ["marker"], ["marker"])
    J = orientation_jacobian(model, Q, names, params)
    R0 = predict_rotations(model, Q, names)
    h = 1e-7
    for k, p in enumerate(params):
        step = np.zeros(len(params))
        step[k] = h
        R1 = predict_rotations(apply_step(model, params, step), Q, names)
        omega = Rotation.from_matrix(R1 @ np.transpose(R0, (0, 2, 1))).as_rotvec() / h
        np.testing.assert_allclose(J[:, k], omega.reshape(-1), atol=1e-5, err_msg=p.name)
    assert np.abs(J).max() > 0.5


def test_measured_rotations_start_near_the_truth(true, meas):
    model = true.copy()
    model.target_rotations.clear()
    truth = tf.rot_vec([0.0, 0.05, 0.5])
    turned = true.copy()
    turned.target_rotations["marker"] = truth
    m = simulate_measurements(turned, 20, rng=1, with_sigma=True, orientation_sigma_deg=SIGMA_DEG)
    start = with_measured_rotations(model, m, ["marker"])
    assert np.degrees(tf.rotation_angle(start.target_rotations["marker"] @ truth.T)) < 0.02


def test_the_last_joint_zero_is_determined_only_with_orientation(nominal, true, meas):
    truth = np.degrees(true.joints[5].theta - nominal.joints[5].theta)
    assert abs(truth) > 0.05                        # a zero offset worth finding
    alone = identify(nominal, meas)
    assert not alone.row("J6.theta").identifiable and alone.row("J6.theta").identified == alone.row("J6.theta").nominal
    free = identify(nominal, meas, orientation=True)
    row = free.row("J6.theta")                      # the marker's turn on the flange absorbs it
    assert not row.identifiable and "marker.rz" in row.explanation and "orientation" in row.explanation
    assert free.orientation.rms_after_deg < 2 * SIGMA_DEG * np.sqrt(3)
    fixed = identify(nominal, meas, orientation=True, fixed=["marker.rz"], holdout=0.25)
    row = fixed.row("J6.theta")
    assert row.identifiable and "only with the measured orientation" in row.explanation
    assert fixed.orientation.determined == ["J6.theta"]
    assert 0 < row.std < 0.02
    assert abs(row.correction - truth) < 4 * row.std, (row.correction, truth, row.std)
    assert len(fixed.estimated) == len(alone.estimated) + 3      # J6.theta, marker.rx, marker.ry
    s = fixed.summary()["orientation"]
    assert s["determined_only_with_orientation"] == ["J6.theta"]
    assert s["holdout_rms_after_deg"] < 2 * SIGMA_DEG * np.sqrt(3) < s["holdout_rms_before_deg"]


def test_orientation_needs_orientations_and_position_sigmas(nominal, meas):
    plain = Measurements(pose=meas.pose, target=meas.target, q_file=meas.q_file, xyz=meas.xyz, sigma=meas.sigma)
    with pytest.raises(RoboCalError, match="no orientations"):
        require_orientations(plain)
    no_sigma = Measurements(pose=meas.pose, target=meas.target, q_file=meas.q_file, xyz=meas.xyz,
                            rotation=meas.rotation, rotation_sigma=meas.rotation_sigma)
    with pytest.raises(RoboCalError, match="sx, sy, sz"):
        identify(nominal, no_sigma, orientation=True)


def test_the_prior_with_orientation_estimates_its_weights_from_every_row(nominal, true, meas):
    """The prior's evidence sees the orientation rows too (without them the marker's rx, ry, rz
    columns are empty and the weights cannot be estimated)."""
    from core.identification.prior import PriorOptions

    plain = identify(nominal, meas, orientation=True, fixed=["marker.rz"])
    prior = identify(nominal, meas, orientation=True, fixed=["marker.rz"], prior=PriorOptions())
    w = prior.prior.weights
    assert prior.prior.chosen_by == "empirical Bayes" and 0 < w.length and 0 < w.angle
    truth = np.degrees(true.joints[5].theta - nominal.joints[5].theta)
    row = prior.row("J6.theta")
    assert abs(row.correction - truth) < 4 * plain.row("J6.theta").std
    assert prior.orientation.rms_after_deg < 2 * SIGMA_DEG * np.sqrt(3)
