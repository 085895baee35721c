"""Placing a once-measured target on the tool: relative to calibrated targets, or from the model;
its covariance propagated from the calibration's and the measurements' noise."""
from __future__ import annotations

import numpy as np
import pytest

from core import transforms as tf
from core.errors import RoboCalError
from core.kinematics.jacobian import all_parameters, predict_points
from core.identification.placement import place_targets
from core.identification.solver import identify
from core.measurement.file import Measurements
from core.monitoring.uncertainty import CalibrationUncertainty, calibration_uncertainty, prediction_covariance
from core.robot.file import read_robot
from core.robot.model import robot_path
from core.virtual_lab.lab import VirtualLab
from core.virtual_lab.synthetic import simulate_measurements


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


def uncertainty(model, blocks: dict[str, np.ndarray], sigma_mm: float = 0.05) -> CalibrationUncertainty:
    """The calibration uncertainty of `model` with only the given parameters' covariance blocks
    ({"p1": 3×3, "base": 3×3 of base.x/y/z}) non-zero."""
    params = all_parameters(model, list(model.targets))
    C = np.zeros((len(params), len(params)))
    for name, block in blocks.items():
        idx = [i for i, p in enumerate(params) if p.name in {f"{name}.{k}" for k in "xyz"}]
        C[np.ix_(idx, idx)] = block
    return CalibrationUncertainty(params, C, sigma_mm)


def test_a_relative_placement_carries_the_reference_s_covariance_and_both_measurements_noise(robot):
    meas = once(robot, np.array([10.0, -20.0, 15.0, 30.0, 40.0, -50.0]))
    Cp1 = np.diag([0.01, 0.02, 0.03]) + 0.004
    placed_robot, placed = place_targets(robot, meas, references=["p1"], uncertainty=uncertainty(robot, {"p1": Cp1}))
    # t = t_p1 + R(q)ᵀ(x_t1 − x_p1): ∂t/∂t_p1 = I, and the two measurements' noise 2σ² per axis
    np.testing.assert_allclose(placed[0].covariance, Cp1 + 2 * 0.05 ** 2 * np.eye(3), atol=1e-9)
    assert placed[0].sigma_mm == pytest.approx(np.sqrt(np.trace(Cp1 + 0.005 * np.eye(3)) / 3))
    assert placed[0].summary()["sigma_mm"] == placed[0].sigma_mm
    # the copy's calibration holds the probe as parameters, correlated with p1 through it
    unc = calibration_uncertainty(placed_robot, sigma_mm=0.05)
    names = unc.names
    t1, p1 = [names.index(f"t1.{k}") for k in "xyz"], [names.index(f"p1.{k}") for k in "xyz"]
    np.testing.assert_allclose(unc.covariance[np.ix_(t1, p1)], Cp1, atol=1e-9)
    np.testing.assert_allclose(unc.covariance[np.ix_(t1, t1)], placed[0].covariance, atol=1e-12)
    assert "t1" not in (robot.calibration or {}).get("covariance", {}).get("parameters", [])


def test_an_absolute_placement_carries_the_base_s_covariance_turned_into_the_tool_frame(robot):
    q_deg = np.array([10.0, -20.0, 15.0, 30.0, 40.0, -50.0])
    Cb = np.diag([0.04, 0.01, 0.09])
    _, placed = place_targets(robot, once(robot, q_deg), names=["t1"], uncertainty=uncertainty(robot, {"base": Cb}))
    R = robot.fk(np.deg2rad(q_deg))[:3, :3]
    # t = R(q)ᵀ(x − o(q)): a base shift moves o(q), so ∂t/∂base.xyz = −R(q)ᵀ; one measurement's noise
    np.testing.assert_allclose(placed[0].covariance, R.T @ Cb @ R + 0.05 ** 2 * np.eye(3), atol=1e-9)


def test_two_references_average_the_noise(robot):
    meas = once(robot, np.zeros(6))
    _, placed = place_targets(robot, meas, references=["p1", "p2"], uncertainty=uncertainty(robot, {}))
    # (t_p1 + Rᵀ(x − x_p1) + t_p2 + Rᵀ(x − x_p2)) / 2: x's noise whole, each reference's halved
    np.testing.assert_allclose(placed[0].covariance, 1.5 * 0.05 ** 2 * np.eye(3), atol=1e-12)


def test_a_check_of_a_placed_target_is_as_wide_as_its_errors_on_the_virtual_lab():
    """Calibrate on the marker, place a probe 37 mm away relative to it from one pose, predict it
    at 4 new poses: over 40 calibrations the errors' Mahalanobis distance under the propagated
    covariance averages 3, a χ² with 3 degrees of freedom (150 trials gave 3.06 ± 0.16)."""
    sigma = 0.05
    lab = VirtualLab.create(read_robot(robot_path("abb_irb120")), seed=0)
    true = lab.true_robot.copy()
    true.targets["probe"] = true.targets["marker"] + np.array([30.0, -20.0, 10.0])
    q0 = np.deg2rad([10.0, 20.0, -10.0, 30.0, 40.0, 50.0])
    distances = []
    for trial in range(40):
        rng = np.random.default_rng(trial)
        model = identify(lab.nominal_robot, simulate_measurements(true, 25, sigma_mm=sigma, targets=["marker"],
                                                                  rng=rng)).model
        unc = calibration_uncertainty(model, sigma_mm=sigma)
        meas = simulate_measurements(true, 1, sigma_mm=sigma, targets=["probe", "marker"], rng=rng, Q=q0[None])
        placed_robot, placed = place_targets(model, meas, references=["marker"], uncertainty=unc)
        assert placed[0].sigma_mm > np.sqrt(2.0) * sigma          # the two measurements' noise and more
        check = simulate_measurements(true, 4, sigma_mm=sigma, targets=["probe"], rng=rng)
        e = check.xyz - predict_points(placed_robot, check.Q, ["probe"] * 4)
        S = prediction_covariance(placed_robot, calibration_uncertainty(placed_robot, sigma_mm=sigma), check.Q,
                                  ["probe"] * 4)
        distances += [e[i] @ np.linalg.solve(S[3 * i:3 * i + 3, 3 * i:3 * i + 3], e[i]) for i in range(4)]
    assert np.mean(distances) == pytest.approx(3.0, abs=0.9)       # ±3 standard errors of 40 trials
