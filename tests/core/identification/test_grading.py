"""Grading a calibration against the lab's true robot: what is compared, the tolerances, the fresh poses."""
from __future__ import annotations

import copy

import numpy as np
import pytest

from core.errors import RoboCalError
from core.identification.grading import ABSORBED_BY_BASE, LAST_JOINT, grade_calibration
from core.identification.file import write_calibrated_model
from core.identification.solver import identify
from core.robot.file import read_robot
from core.virtual_lab.ideal_measurements import ideal_lab_measurements
from core.virtual_lab.lab import VirtualLab


@pytest.fixture(scope="module")
def graded_lab(tmp_path_factory):
    lab = VirtualLab.create(seed=3)
    result = identify(lab.nominal_robot, ideal_lab_measurements(lab, 40, sigma_mm=0.05, seed=1))
    path = write_calibrated_model(result, tmp_path_factory.mktemp("grade") / "calibrated.json")
    Q = lab.random_visible_poses(30, np.random.default_rng(5))
    return lab, read_robot(path), Q


def test_a_good_calibration_gets_every_mark_and_the_left_out_parameters_say_why(graded_lab):
    lab, student, Q = graded_lab
    r = grade_calibration(student, lab.true_robot, Q, lab.target)
    assert r.marks == r.out_of == len(r.parameters) + 1
    names = {p.name for p in r.parameters}
    assert {"J2.a", "J3.d", "J4.theta", "J5.alpha"} <= names
    assert not names & {"J1.theta", "J1.d", "J2.d", "J6.theta", "J6.d", "J6.a", "J6.alpha"}
    assert r.excluded["J1.theta"] == r.excluded["J1.d"] == ABSORBED_BY_BASE
    assert r.excluded["J6.theta"] == LAST_JOINT and "Hayati" in r.excluded["J2.d"]
    # noise of 0.05 mm only: the model is within a few hundredths of a mm at poses it never saw
    assert r.fresh_rms_mm < 0.05 and r.fresh_passed
    assert all(p.sigma_stereo == 0.0 for p in r.parameters) and r.notes
    for p in r.parameters:                                     # against the truth the lab made
        assert abs(p.difference) <= 3 * p.sigma_student


def test_a_wrong_parameter_is_marked_off(graded_lab):
    lab, student, Q = graded_lab
    wrong = copy.deepcopy(student)
    wrong.joints[2].a += 1.0                                   # J3.a one millimetre off
    r = grade_calibration(wrong, lab.true_robot, Q, lab.target)
    off = [p.name for p in r.parameters if not p.passed]
    assert off == ["J3.a"] and not r.fresh_passed and r.marks == r.out_of - 2


def test_the_stereo_calibrations_error_widens_the_tolerances(graded_lab):
    lab, student, Q = graded_lab
    truth = lab.true_robot.target_positions(Q, lab.target)
    shift = truth * 0.001                                      # a baseline 0.1 % long scales every point
    r = grade_calibration(student, lab.true_robot, Q, lab.target, stereo_shift=shift)
    sigma = {p.name: p.sigma_stereo for p in r.parameters}
    assert sigma["J2.a"] == pytest.approx(0.001 * abs(lab.true_robot.joints[1].a), rel=0.05)   # a length scales
    assert sigma["J2.theta"] < 1e-3                           # an angle does not
    assert "RMS" in r.stereo_error and not r.notes


def test_a_file_without_calibration_is_refused(graded_lab):
    lab, _, Q = graded_lab
    with pytest.raises(RoboCalError, match="no calibration to grade"):
        grade_calibration(lab.nominal_robot, lab.true_robot, Q, lab.target, source="robot.json")
