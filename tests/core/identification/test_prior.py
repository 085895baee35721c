"""The prior toward nominal (Tikhonov on the DH corrections), its weights estimated by empirical Bayes."""
from __future__ import annotations

import numpy as np
import pytest

from core.errors import RoboCalError
from core.kinematics.identifiability import NOT_DETERMINED, random_configurations
from core.kinematics.jacobian import display_value
from core.identification.prior import EMPIRICAL_BAYES, PRIOR_DOMINATED, PriorOptions, log_evidence
from core.identification.fit import evaluate, fit_model
from core.identification.solver import identify
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
    assert zero.prior.weights.plain and zero.prior.dominated == []


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


def test_the_estimated_weights_reproduce(arm):
    nominal, true = arm
    Q = random_configurations(nominal, 30, seed=5)
    Q[:, 5] = 0.3
    meas = simulate_measurements(true, len(Q), sigma_mm=0.02, Q=Q, rng=4)
    first = identify(nominal, meas, prior=PriorOptions())
    again = identify(nominal, meas, prior=PriorOptions())
    # the plain fit cannot be made on these poses; the estimated weights are positive
    assert first.prior.chosen_by == EMPIRICAL_BAYES
    assert first.prior.weights.length > 0 and first.prior.weights.angle > 0
    assert again.prior.weights == first.prior.weights
    given = fit_model(nominal, meas, prior_weights=first.prior.weights)
    for prm in first.identifiability.free:
        assert display_value(given.model, prm) == pytest.approx(first.row(prm.name).identified, abs=1e-9), prm.name


def test_estimated_weights_beat_keeping_barely_determined_parameters_at_nominal():
    """The 6R arm with its marker 0.36 mm off the last axis (bench prior_study, run 0): the plain
    fit keeps J5.theta and J5.d at nominal; the prior with estimated weights predicts the true
    robot better. Measured 0.04755 against 0.04840 mm (0.982); over 10 runs 0.878–1.009."""
    nominal = read_robot(robot_path("educational_6r"))
    nominal.targets = {"marker": np.array([0.0, 0.0, 25.0])}
    true = perturbed_model(nominal, 0, target_mm=0.0)
    true.targets = {"marker": np.array([0.3, 0.2, 25.0])}
    meas = simulate_measurements(true, 30, sigma_mm=0.05, rng=100)
    truth = simulate_measurements(true, 200, sigma_mm=0.0, rng=999)
    plain = identify(nominal, meas)
    assert {"J5.theta", "J5.d"} <= {r.name for r in plain.unidentifiable if r.status == NOT_DETERMINED}
    prior = identify(nominal, meas, prior=PriorOptions())
    # σ = 0.05 mm and corrections of about 1 mm: λ_L near σ²/(1 mm)² = 0.0025
    assert 1e-3 < prior.prior.weights.length < 1e-2 and prior.prior.weights.angle > 0
    ratio = evaluate(prior.model, truth).mean_mm / evaluate(plain.model, truth).mean_mm
    assert ratio < 0.99


def test_evidence_finds_the_prior_scale_of_a_linear_problem():
    """Corrections drawn with std τ = 0.5 (λ = σ²/τ² = 0.01 for σ = 0.05): the evidence's
    maximum lies within a factor 2 of it (60 parameters with a prior, 6 without)."""
    rng = np.random.default_rng(3)
    m, q, r, sigma, tau = 600, 60, 6, 0.05, 0.5
    J = rng.normal(size=(m, q + r))
    P = np.hstack([np.eye(q), np.zeros((q, r))])
    truth = np.concatenate([rng.normal(0, tau, q), rng.normal(0, 100, r)])
    b = J @ truth + rng.normal(0, sigma, m)
    evidence = log_evidence(J, b, P, np.zeros(q))
    grid = np.logspace(-5, 1, 61)
    best = grid[int(np.argmax([evidence(np.full(q, lam)) for lam in grid]))]
    assert 0.005 < best < 0.02


def test_prior_options_are_bounded():
    with pytest.raises(RoboCalError, match="prior weight"):
        PriorOptions(weight=-1.0)
