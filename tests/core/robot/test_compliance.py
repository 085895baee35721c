"""Joint compliance: the deflection inside forward kinematics, its derivative, the identification
Jacobian of its coefficients against finite differences, the file section and the refusals."""
from __future__ import annotations

import json

import numpy as np
import pytest

from core.errors import RoboCalError
from core.kinematics.identifiability import random_configurations
from core.kinematics.jacobian import (all_parameters, apply_step, calibration_jacobian, expand_poses,
                                      parameter_difference, predict_points)
from core.robot.compliance import DEFAULT_TERMS, SHAPES, Compliance, check_vertical_arm
from core.robot.file import read_robot, robot_to_dict, write_robot
from core.robot.model import PRISMATIC, Joint, RobotModel, robot_path
from core.virtual_lab.synthetic import perturbed_model


def deflecting(name: str = "abb_irb120", seed: int = 0) -> RobotModel:
    model = perturbed_model(read_robot(robot_path(name)), seed, length_mm=1.0, angle_deg=0.3)
    model.compliance = Compliance.zero(model.dof)
    rng = np.random.default_rng(seed)
    for joint, shape in DEFAULT_TERMS:
        model.compliance.set(joint, shape, np.deg2rad(rng.uniform(-0.05, 0.05)))
    return model


def test_forward_kinematics_is_the_rigid_arm_at_the_deflected_joint_values():
    model = deflecting()
    rigid = model.copy()
    rigid.compliance = None
    Q = random_configurations(model, 8, seed=1)
    c = model.compliance.coefficients
    q2, q23 = Q[:, 1], Q[:, 1] + Q[:, 2]
    # δq written out by hand from the shapes' definition
    dq2 = c[1, 0] * np.sin(q2) + c[1, 1] * np.cos(q2) + c[1, 2] * np.sin(q23) + c[1, 3] * np.cos(q23)
    dq3 = c[2, 2] * np.sin(q23) + c[2, 3] * np.cos(q23)
    moved = Q.copy()
    moved[:, 1] += dq2
    moved[:, 2] += dq3
    np.testing.assert_allclose(model.fk_many(Q), rigid.fk_many(moved), atol=1e-12)
    # the deflection is not negligible: 0.05° at 600 mm moves the tool by tenths of a millimetre
    assert np.max(np.linalg.norm(model.fk_many(Q)[:, :3, 3] - rigid.fk_many(Q)[:, :3, 3], axis=1)) > 0.05


def test_derivative_of_the_deflection_matches_central_differences():
    c = deflecting().compliance
    Q = random_configurations(deflecting(), 5, seed=2)
    D = c.derivative(Q)
    h = 1e-6
    for i in range(Q.shape[1]):
        step = np.zeros(Q.shape[1])
        step[i] = h
        numeric = (c.deflection(Q + step) - c.deflection(Q - step)) / (2 * h)
        np.testing.assert_allclose(D[:, :, i], numeric, atol=1e-10)


@pytest.mark.parametrize("name", ["abb_irb120", "ur5", "puma560"])
def test_jacobian_of_the_coefficients_matches_central_differences(name):
    model = deflecting(name, seed=4)
    params = all_parameters(model, ["marker"], compliance=True)
    names = [p.name for p in params]
    assert names[-6:] == ["J2.sin_q2", "J2.cos_q2", "J2.sin_q23", "J2.cos_q23", "J3.sin_q23", "J3.cos_q23"]
    Q, targets = expand_poses(random_configurations(model, 6, seed=3), ["marker"])
    J = calibration_jacobian(model, Q, targets, params)
    h = 1e-6
    Jn = np.zeros_like(J)
    for k in range(len(params)):
        d = np.zeros(len(params))
        d[k] = h
        Jn[:, k] = (predict_points(apply_step(model, params, d), Q, targets)
                    - predict_points(apply_step(model, params, -d), Q, targets)).reshape(-1) / (2 * h)
    scale = np.abs(Jn).max(axis=0)
    assert np.all(scale > 0)
    rel = np.abs(J - Jn).max(axis=0) / scale
    assert rel.max() < 1e-6, params[int(np.argmax(rel))].name


def test_parameter_difference_recovers_a_step_in_the_coefficients():
    model = deflecting()
    params = all_parameters(model, ["marker"], compliance=True)
    step = np.zeros(len(params))
    step[-6:] = np.deg2rad([0.01, -0.02, 0.03, 0.0, 0.015, -0.01])
    moved = apply_step(model, params, step)
    np.testing.assert_allclose(parameter_difference(moved, model, params)[-6:], step[-6:], atol=1e-15)
    assert model.compliance.coefficient(1, "sin_q2") != moved.compliance.coefficient(1, "sin_q2")


def test_file_round_trip_keeps_the_coefficients_in_degrees(tmp_path):
    model = deflecting()
    path = write_robot(model, tmp_path / "robot.json")
    data = json.loads(path.read_text())
    section = data["compliance"]
    assert section["format"] == "robocal.compliance/1" and section["unit"] == "deg"
    assert set(section["joints"]) == {"J2", "J3"} and set(section["joints"]["J3"]) == {"sin_q23", "cos_q23"}
    assert section["joints"]["J2"]["cos_q2"] == pytest.approx(np.rad2deg(model.compliance.coefficient(1, "cos_q2")))
    back = read_robot(path)
    np.testing.assert_allclose(back.compliance.coefficients, model.compliance.coefficients, atol=1e-15)
    assert back.compliance.terms == model.compliance.terms
    Q = random_configurations(model, 4, seed=5)
    np.testing.assert_allclose(back.fk_many(Q), model.fk_many(Q), atol=1e-9)


def test_a_file_without_the_section_is_a_rigid_arm(tmp_path):
    model = read_robot(robot_path("abb_irb120"))
    assert model.compliance is None
    assert "compliance" not in robot_to_dict(model)


@pytest.mark.parametrize("section, field, words", [
    ({"format": "robocal.compliance/2", "joints": {}}, "format", "unknown format version 2"),
    ({"format": "robocal.compliance/1", "joints": {"J9": {"sin_q2": 0.1}}}, "compliance.joints.J9", "unknown joint"),
    ({"format": "robocal.compliance/1", "joints": {"J2": {"sin_q4": 0.1}}}, "compliance.joints.J2.sin_q4",
     "unknown shape"),
    ({"format": "robocal.compliance/1", "joints": {"J2": {"sin_q2": "0.1"}}}, "compliance.joints.J2.sin_q2",
     "expected a number"),
    ({"format": "robocal.compliance/1", "gravity": [0, 0, 0], "joints": {}}, "compliance.gravity", "zero"),
    ({"format": "robocal.compliance/1", "unit": "rad", "joints": {}}, "compliance.unit", "unsupported unit"),
])
def test_bad_sections_name_the_field(tmp_path, section, field, words):
    data = robot_to_dict(read_robot(robot_path("abb_irb120")))
    data["compliance"] = section
    path = tmp_path / "robot.json"
    path.write_text(json.dumps(data))
    with pytest.raises(RoboCalError) as err:
        read_robot(path)
    assert err.value.field == field and words in err.value.problem


def scara() -> RobotModel:
    joints = [Joint(theta=0.0, d=300.0, a=250.0, alpha=0.0, min=-2.5, max=2.5),
              Joint(theta=0.0, d=0.0, a=200.0, alpha=np.pi, min=-2.5, max=2.5),
              Joint(type=PRISMATIC, theta=0.0, d=0.0, a=0.0, alpha=0.0, min=0.0, max=150.0),
              Joint(theta=0.0, d=0.0, a=0.0, alpha=0.0, min=-3.0, max=3.0)]
    return RobotModel("SCARA", joints, targets={"marker": np.array([0.0, 0.0, 30.0])})


def test_refusals_name_what_is_wrong():
    with pytest.raises(RoboCalError, match="joint J3 of 'SCARA' is prismatic"):
        check_vertical_arm(scara())
    revolute = scara()
    revolute.joints[2].type = "revolute"
    with pytest.raises(RoboCalError, match="J2 of 'SCARA' is not horizontal"):
        check_vertical_arm(revolute)
    wall = read_robot(robot_path("abb_irb120"))
    wall.compliance = Compliance.zero(6, gravity=(1.0, 0.0, 0.0))       # mounted on a wall
    with pytest.raises(RoboCalError, match="J1 of .* is not vertical") as err:
        check_vertical_arm(wall)
    assert "--compliance off" in err.value.hint
    two = RobotModel("planar", [Joint(min=-1, max=1), Joint(min=-1, max=1)])
    with pytest.raises(RoboCalError, match="has 2 joints"):
        check_vertical_arm(two)


@pytest.mark.parametrize("name", ["abb_irb120", "ur5", "puma560", "kuka_kr6_r900", "educational_6r"])
def test_vertical_arms_are_accepted(name):
    model = read_robot(robot_path(name))
    model.compliance = Compliance.zero(model.dof)
    check_vertical_arm(model)             # no error
    assert model.compliance.is_zero and SHAPES[0] == "sin_q2"


def test_check_limits_include_the_deflection_terms_through_the_covariance():
    """A calibration with deflection terms: their covariance enters the predicted uncertainty of a
    check pose through the Jacobian (core.monitoring.uncertainty)."""
    from core.identification.solver import identify
    from core.monitoring.uncertainty import calibration_uncertainty, prediction_covariance
    from core.virtual_lab.ideal_measurements import ideal_lab_measurements
    from core.virtual_lab.lab import VirtualLab

    lab = VirtualLab.create(read_robot(robot_path("abb_irb120")), seed=0, deflection=True)
    result = identify(lab.nominal_robot, ideal_lab_measurements(lab, 40, sigma_mm=0.05, seed=0), compliance="on")
    unc = calibration_uncertainty(result.model)
    names = unc.names
    assert "J2.cos_q2" in names and "J3.sin_q23" in names
    Q = lab.random_visible_poses(5, 7)
    S = prediction_covariance(result.model, unc, Q, ["marker"] * 5)
    keep = [k for k, p in enumerate(unc.parameters) if p.group != "compliance"]
    geometric = type(unc)(parameters=[unc.parameters[k] for k in keep], covariance=unc.covariance[np.ix_(keep, keep)],
                          sigma_mm=unc.sigma_mm)
    S_geo = prediction_covariance(result.model, geometric, Q, ["marker"] * 5)
    # the deflection terms' own uncertainty (and their correlations) change the predicted spread
    assert not np.allclose(np.diag(S), np.diag(S_geo), rtol=1e-3)
