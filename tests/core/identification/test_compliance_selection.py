"""Deflection terms in identification: off / on / auto, the one-standard-error rule, the verdict,
the payload in the calibration record and the refusals."""
from __future__ import annotations

import numpy as np
import pytest

from core.errors import RoboCalError, UsageError
from core.identification.compliance_selection import decide
from core.identification.fit import error_stats
from core.identification.solver import identify
from core.robot.compliance import Compliance
from core.robot.file import read_robot, write_robot
from core.robot.model import PRISMATIC, Joint, RobotModel, robot_path
from core.virtual_lab.ideal_measurements import ideal_lab_measurements
from core.virtual_lab.lab import VirtualLab
from core.virtual_lab.synthetic import simulate_measurements


@pytest.fixture(scope="module")
def irb120():
    return read_robot(robot_path("abb_irb120"))


def test_one_standard_error_rule():
    rng = np.random.default_rng(0)
    off = 0.30 + 0.05 * rng.standard_normal(30)
    better = off - 0.12                        # clearly better: kept
    choice = decide(off, better, 5, 0.01)
    assert choice.kept and choice.weight == 0.01
    assert choice.gain_mm == pytest.approx(0.12)
    assert "bends under its weight" in choice.verdict and "0.120 mm of the error is deflection" in choice.verdict
    slightly = off - 0.5 * better.std(ddof=1) / np.sqrt(30)      # better by half a standard error: declined
    choice = decide(off, slightly, 5, 0.01)
    assert not choice.kept and choice.weight is None
    assert "No clear gain with 30 poses" in choice.verdict and choice.verdict.endswith("geometry only.")
    choice = decide(off, off + 0.01, 5, 0.01)
    assert not choice.kept and choice.verdict.startswith("No gain with 30 poses")


def test_rigid_robot_with_few_poses_declines_and_matches_the_geometric_fit(irb120):
    lab = VirtualLab.create(irb120, seed=3)
    meas = ideal_lab_measurements(lab, 20, sigma_mm=0.05, seed=3)
    test = ideal_lab_measurements(lab, 20, sigma_mm=0.05, seed=103)
    auto = identify(lab.nominal_robot, meas, compliance="auto")
    off = identify(lab.nominal_robot, meas, compliance="off")
    assert not auto.compliance.kept and auto.model.compliance is None
    assert "geometry only" in auto.compliance.verdict and auto.compliance.n_poses == 20
    assert error_stats(auto.model, test).mean_mm == pytest.approx(error_stats(off.model, test).mean_mm, rel=0.02)
    assert not any(r.group == "compliance" for r in auto.parameters)
    record = auto.calibration_section()["statistics"]["compliance"]
    assert record["mode"] == "auto" and record["kept"] is False and record["verdict"] == auto.compliance.verdict


def test_deflecting_robot_keeps_the_terms_and_finds_the_true_coefficients(irb120, tmp_path):
    lab = VirtualLab.create(irb120, seed=1, deflection=True)
    assert lab.true_robot.compliance is not None and lab.nominal_robot.compliance is None
    meas = ideal_lab_measurements(lab, 60, sigma_mm=0.05, seed=1)
    test = ideal_lab_measurements(lab, 30, sigma_mm=0.05, seed=101)
    result = identify(lab.nominal_robot, meas, compliance="auto", payload_kg=1.5)
    assert result.compliance.kept, result.compliance.verdict
    assert "bends under its weight" in result.compliance.verdict
    rows = [r for r in result.parameters if r.group == "compliance"]
    assert [r.name for r in rows] == ["J2.sin_q2", "J2.cos_q2", "J2.sin_q23", "J2.cos_q23", "J3.sin_q23",
                                      "J3.cos_q23"]
    z = [(r.identified - np.rad2deg(lab.true_robot.compliance.coefficient(int(r.name[1]) - 1, r.kind))) / r.std
         for r in rows]
    assert np.max(np.abs(z)) < 4.0, z
    floor = error_stats(lab.true_robot, test).mean_mm
    assert error_stats(result.model, test).mean_mm < 1.2 * floor
    # the record: payload, verdict, and the coefficients in the written file
    section = result.calibration_section()
    assert section["payload_kg"] == 1.5 and section["statistics"]["compliance"]["kept"] is True
    assert "J2.cos_q2" in section["covariance"]["parameters"]
    back = read_robot(write_robot(result.model, tmp_path / "calibrated.json"))
    np.testing.assert_allclose(back.compliance.coefficients, result.model.compliance.coefficients, atol=1e-14)
    assert back.calibration["payload_kg"] == 1.5


def test_off_drops_a_model_s_own_terms_with_a_note(irb120):
    lab = VirtualLab.create(irb120, seed=2)
    meas = ideal_lab_measurements(lab, 20, sigma_mm=0.05, seed=2)
    robot = lab.nominal_robot.copy()
    robot.compliance = Compliance.zero(robot.dof)
    robot.compliance.set(1, "cos_q2", 1e-3)
    result = identify(robot, meas)
    assert result.model.compliance is None
    assert any("deflection terms were dropped" in w for w in result.warnings)
    assert result.compliance.verdict == "Geometry only: deflection terms not asked for."


def test_refusals():
    scara = RobotModel("SCARA", [Joint(d=300.0, a=250.0, min=-2.5, max=2.5),
                                 Joint(a=200.0, alpha=np.pi, min=-2.5, max=2.5),
                                 Joint(type=PRISMATIC, min=0.0, max=150.0),
                                 Joint(min=-3.0, max=3.0)], targets={"marker": np.array([0.0, 0.0, 30.0])})
    lab = VirtualLab.create(read_robot(robot_path("abb_irb120")), seed=0)
    meas = ideal_lab_measurements(lab, 12, sigma_mm=0.05, seed=0)
    with pytest.raises(RoboCalError, match="joint J3 of 'SCARA' is prismatic") as err:
        identify(scara, simulate_measurements(scara, 12), compliance="on")
    assert err.value.field == "--compliance" and "--compliance off" in err.value.hint
    with pytest.raises(UsageError, match="unknown deflection choice 'maybe'"):
        identify(lab.nominal_robot, meas, compliance="maybe")
    with pytest.raises(UsageError, match="payload"):
        identify(lab.nominal_robot, meas, payload_kg=-1.0)
    wall = read_robot(robot_path("abb_irb120"))
    wall.compliance = Compliance.zero(6, gravity=(1.0, 0.0, 0.0))      # mounted on a wall
    with pytest.raises(RoboCalError, match="J1 of .* is not vertical"):
        VirtualLab.create(wall, seed=0, deflection=True)
