"""The prior toward nominal (Tikhonov on the DH corrections), its weight chosen by cross validation."""
from __future__ import annotations

import numpy as np
import pytest

from core.errors import RoboCalError
from core.identification.identifiability import random_configurations
from core.identification.prior import PRIOR_DOMINATED, PriorOptions, choose_weight
from core.identification.solver import evaluate, fit_model, identify
from core.robot.file import read_robot
from core.robot.model import robot_path
from core.virtual_lab.synthetic import perturbed_model, simulate_measurements

J5 = ["J5.theta", "J5.d", "J5.a", "J5.alpha"]


@pytest.fixture(scope="module")
def arm():
    nominal = read_robot(robot_path("educational_6r"))
    nominal.targets = {"marker": np.array([20.0, 10.0, 30.0])}
    return nominal, perturbed_model(nominal, 3)


def test_weight_zero_is_the_plain_fit(arm):
    nominal, true = arm
    meas = simulate_measurements(true, 30, sigma_mm=0.05, rng=1)
    plain = identify(nominal, meas)
    zero = identify(nominal, meas, prior=PriorOptions(weight=0.0))
    assert zero.estimated == plain.estimated
    for a, b in zip(plain.parameters, zero.parameters):
        assert (a.name, a.status) == (b.name, b.status)
        assert b.identified == pytest.approx(a.identified, abs=1e-12), a.name
    assert zero.prior.weight == 0.0 and zero.prior.dominated == []


def test_a_small_weight_moves_the_fit_continuously(arm):
    nominal, true = arm
    meas = simulate_measurements(true, 30, sigma_mm=0.05, rng=1)
    plain = identify(nominal, meas)
    tiny = identify(nominal, meas, prior=PriorOptions(weight=1e-9))
    strong = identify(nominal, meas, prior=PriorOptions(weight=1e3))
    d_tiny = max(abs(a.identified - b.identified) for a, b in zip(plain.parameters, tiny.parameters)
                 if a.group == "joint")
    assert d_tiny < 1e-3
    # a strong prior holds the DH values near nominal: its corrections are far smaller than the plain fit's
    big = max(abs(r.correction) for r in plain.parameters if r.group == "joint" and r.unit == "mm")
    held = max(abs(r.correction) for r in strong.parameters if r.group == "joint" and r.unit == "mm")
    assert held < 0.2 * big


def test_a_parameter_the_data_cannot_see_stays_at_nominal_and_is_reported(arm):
    nominal, true = arm
    Q = random_configurations(nominal, 40, seed=5)
    Q[:, 5] = 0.3                       # the last joint never moves: J5's geometry is lost in the target offset
    meas = simulate_measurements(true, len(Q), sigma_mm=0.02, Q=Q, rng=4)
    with pytest.raises(RoboCalError, match="cannot determine"):
        identify(nominal, meas)
    result = identify(nominal, meas, prior=PriorOptions(weight=1e-3))
    for name in J5:
        row = result.row(name)
        assert row.identifiable and row.status == PRIOR_DOMINATED, name
        assert row.data_share < 1e-6
        assert abs(row.correction) < 1e-6, (name, row.correction)
        assert name in result.prior.dominated
    assert result.prior.shares["J2.a"] > 0.9          # what the data determine is not dominated
    assert "J2.a" not in result.prior.dominated
    Q_test = random_configurations(nominal, 30, seed=8)
    Q_test[:, 5] = 0.3
    test = simulate_measurements(true, len(Q_test), sigma_mm=0.0, Q=Q_test, rng=0)
    assert evaluate(result.model, test).rms_mm < 0.1
    assert result.calibration_section()["statistics"]["prior"]["dominated"] == result.prior.dominated


def test_the_chosen_weight_reproduces(arm):
    nominal, true = arm
    Q = random_configurations(nominal, 30, seed=5)
    Q[:, 5] = 0.3
    meas = simulate_measurements(true, len(Q), sigma_mm=0.02, Q=Q, rng=4)
    first = identify(nominal, meas, prior=PriorOptions(folds=4), seed=2)
    again = identify(nominal, meas, prior=PriorOptions(folds=4), seed=2)
    # the plain fit cannot be made on these poses, so cross validation must choose a prior
    assert first.prior.cv_rms_mm[0.0] == np.inf
    assert first.prior.weight > 0 and first.prior.chosen_by == "4-fold cross validation"
    assert again.prior.weight == first.prior.weight and again.prior.cv_rms_mm == first.prior.cv_rms_mm
    given = identify(nominal, meas, prior=PriorOptions(weight=first.prior.weight))
    for a, b in zip(first.parameters, given.parameters):
        assert b.identified == pytest.approx(a.identified, abs=1e-9), a.name
    assert min(first.prior.cv_rms_mm.values()) == first.prior.cv_rms_mm[first.prior.weight]


def test_cross_validation_keeps_the_plain_fit_unless_a_prior_predicts_clearly_better(arm):
    nominal, true = arm
    meas = simulate_measurements(true, 40, sigma_mm=0.05, rng=7)

    def fit(train, weight, monitor):
        return fit_model(nominal, train, prior_weight=weight, monitor=monitor).model
    choice = choose_weight(meas, fit, folds=5, seed=0, weights=(0.0, 1e3))
    # a prior of 1000 holds corrections of about 1 mm at nominal: it predicts far worse
    assert choice.weight == 0.0
    assert choice.rms_mm[1e3] > 3 * choice.rms_mm[0.0]


def test_prior_options_are_bounded():
    with pytest.raises(RoboCalError, match="prior weight"):
        PriorOptions(weight=-1.0)
    with pytest.raises(RoboCalError, match="folds"):
        PriorOptions(folds=1)
