"""Identification: analytic Jacobian, identifiability, LM estimation, uncertainty, validation.

Synthetic truth only: a perturbed preset, its forward kinematics plus Gaussian noise.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from core import transforms as tf
from core.kinematics.jacobian import (all_parameters, apply_step, calibration_jacobian, expand_poses, hayati_joints,
                                      parameter_difference, predict_points, resolve_names)
from core.errors import Cancelled, RoboCalError, UsageError
from core.kinematics.identifiability import (FIXED_BY_USER, HAYATI, NOT_IDENTIFIABLE, analyse, check_data,
                                             observability_indices, observation_matrix, random_configurations)
from core.identification.fit import error_stats, evaluate, register_base
from core.identification.file import identify_files, write_calibrated_model
from core.identification.solver import identify
from core.identification.validation import kfold_poses, split_poses
from core.robot.model import PRISMATIC, Joint, RobotModel, robot_path
from core.measurement.file import write_measurements
from core.robot.file import read_robot
from core.virtual_lab.synthetic import perturbed_model, simulate_measurements

PRESETS = ["educational_6r", "puma560", "ur5", "abb_irb120"]


@pytest.fixture(scope="module")
def presets():
    return {name: read_robot(robot_path(name)) for name in PRESETS}


def prismatic_robot() -> RobotModel:
    joints = [Joint(theta=0.1, d=200.0, a=10.0, alpha=np.pi / 2, min=-2.5, max=2.5),
              Joint(type=PRISMATIC, theta=np.pi / 2, d=100.0, a=5.0, alpha=-np.pi / 2, min=0.0, max=300.0),
              Joint(theta=0.0, d=50.0, a=80.0, alpha=0.0, min=-2.5, max=2.5),
              Joint(theta=0.2, d=0.0, a=60.0, alpha=0.3, min=-2.5, max=2.5)]
    return RobotModel("prismatic test", joints, targets={"marker": np.array([5.0, 3.0, 40.0])})


def numeric_jacobian(model, Q, names, params, h=1e-6):
    J = np.zeros((3 * len(Q), len(params)))
    for k in range(len(params)):
        d = np.zeros(len(params))
        d[k] = h
        plus = predict_points(apply_step(model, params, d), Q, names).reshape(-1)
        minus = predict_points(apply_step(model, params, -d), Q, names).reshape(-1)
        J[:, k] = (plus - minus) / (2 * h)
    return J


# -- Jacobian ------------------------------------------------------------------------------
@pytest.mark.parametrize("name", PRESETS + ["prismatic"])
def test_analytic_jacobian_matches_central_differences(presets, name):
    nominal = prismatic_robot() if name == "prismatic" else presets[name]
    model = perturbed_model(nominal, 7, length_mm=2.0, angle_deg=1.0)
    for j in model.joints:           # β ≠ 0 on every joint, not only on the Hayati ones
        j.beta += 0.01
    model.targets["tip"] = np.array([12.0, -7.0, 90.0])
    params = all_parameters(model, ["marker", "tip"])
    Q, names = expand_poses(random_configurations(model, 6, seed=3), ["marker", "tip"])
    J = calibration_jacobian(model, Q, names, params)
    Jn = numeric_jacobian(model, Q, names, params)
    scale = np.abs(Jn).max(axis=0)
    rel = np.abs(J - Jn).max(axis=0) / scale
    assert np.all(scale > 0)
    assert rel.max() < 1e-6, params[int(np.argmax(rel))].name


def test_parameter_names_and_hayati_beta(presets):
    names6 = [p.name for p in all_parameters(presets["educational_6r"], ["marker"])]
    assert "J2.beta" in names6 and "J3.beta" not in names6 and "J1.beta" not in names6
    assert names6[-9:] == ["base.x", "base.y", "base.z", "base.rx", "base.ry", "base.rz",
                           "marker.x", "marker.y", "marker.z"]
    ur5 = [p.name for p in all_parameters(presets["ur5"], ["marker"])]
    assert "J2.beta" in ur5 and "J3.beta" in ur5 and "J4.beta" not in ur5
    params = all_parameters(presets["puma560"], ["marker"])
    assert resolve_names(["j2.A", " base.rz", "marker.x", ""], params, presets["puma560"]) == \
        ["J2.a", "base.rz", "marker.x"]
    with pytest.raises(UsageError, match="unknown parameter 'J9.a'"):
        resolve_names(["J9.a"], params, presets["puma560"])


def test_apply_step_and_parameter_difference_round_trip(presets):
    model = perturbed_model(presets["ur5"], 2)
    params = all_parameters(model, ["marker"])
    delta = np.random.default_rng(0).normal(0, 1e-3, len(params))
    moved = apply_step(model, params, delta)
    np.testing.assert_allclose(parameter_difference(moved, model, params), delta, atol=1e-12)


# -- identifiability -----------------------------------------------------------------------
def test_structural_identifiability_of_the_6r_arm(presets):
    model = presets["educational_6r"].copy()
    model.base = tf.pose_to_matrix([0, 0, 1000], [0, 0, 0])   # base z along the measurement z
    ident = analyse(model, ["marker"])
    status = {e.name: e.status for e in ident.excluded}
    assert status["J1.theta"] == NOT_IDENTIFIABLE and status["J1.d"] == NOT_IDENTIFIABLE
    assert status["J2.d"] == HAYATI
    assert {"J6.d", "J6.a", "J6.alpha", "J6.theta"} <= set(status)
    assert all(p.group in ("joint", "base", "target") for p in ident.free)
    assert {"base.x", "base.y", "base.z", "base.rx", "base.ry", "base.rz", "marker.x", "marker.y",
            "marker.z", "J2.beta"} <= set(ident.free_names)
    theta1 = ident.exclusion("J1.theta")
    assert theta1.partners == ("base.rz",)
    assert theta1.explanation == ("J1.theta cannot be told apart from base.rz: both rotate the whole arm about "
                                  "the first joint axis. It is kept at its nominal value and base.rz absorbs it.")
    assert ident.exclusion("J1.d").partners == ("base.z",)
    assert "parallel" in ident.exclusion("J2.d").explanation and "Hayati" in ident.exclusion("J2.d").explanation
    assert "target offset" in ident.exclusion("J6.d").explanation


def test_fixing_parameters_by_name(presets):
    model = perturbed_model(presets["educational_6r"], 1)
    ident = analyse(model, ["marker"], fixed=["J3.a", "marker.z"])
    assert ident.exclusion("J3.a").status == FIXED_BY_USER
    assert ident.exclusion("marker.z").status == FIXED_BY_USER
    assert "J3.a" not in ident.free_names
    # with the target's z fixed, a parameter of the last joint takes over its role
    free_before = analyse(model, ["marker"], fixed=["J3.a"]).free_names
    assert len(ident.free_names) == len(free_before)
    assert any(n.startswith("J6.") for n in ident.free_names)
    assert not any(n.startswith("J6.") for n in free_before)


def test_ur5_three_parallel_axes(presets):
    ident = analyse(perturbed_model(presets["ur5"], 1), ["marker"])
    assert ident.exclusion("J2.d").status == HAYATI and ident.exclusion("J3.d").status == HAYATI
    assert "J4.d absorbs it" in ident.exclusion("J3.d").explanation
    assert {"J2.beta", "J3.beta", "J4.d"} <= set(ident.free_names)


def test_observability_indices_definitions():
    phi = np.zeros((6, 3))
    phi[0, 0], phi[1, 1], phi[2, 2] = 4.0, 2.0, 1.0        # singular values 4, 2, 1 (unscaled)
    o = observability_indices(phi, n_points=2, scales=np.ones(3))
    assert o.rank == 3 and o.condition_number == pytest.approx(4.0)
    assert o.o1 == pytest.approx((4 * 2 * 1) ** (1 / 3) / math.sqrt(2))
    assert o.o2 == pytest.approx(0.25) and o.o3 == pytest.approx(1.0)
    assert o.o4 == pytest.approx(1.0 / 4.0)
    assert o.o5 == pytest.approx(1.0 / (1 / 16 + 1 / 4 + 1))
    scaled = observability_indices(phi)                      # default: column-norm scaling
    assert scaled.condition_number == pytest.approx(1.0)
    phi[:, 2] = phi[:, 0]                                    # dependent columns
    bad = observability_indices(phi, scales=np.ones(3))
    assert bad.rank == 2 and math.isinf(bad.condition_number) and bad.o1 == 0 and bad.o3 == 0


def test_observation_matrix_for_pose_selection(presets):
    model = presets["educational_6r"]
    Q = random_configurations(model, 20, seed=1)
    phi, names = observation_matrix(model, Q)
    ident = analyse(model, ["marker"])
    assert names == ident.free_names and phi.shape == (60, len(names))
    full, all_names = observation_matrix(model, Q, identifiable_only=False)
    assert full.shape == (60, len(all_parameters(model, ["marker"]))) and "J1.theta" in all_names
    assert observability_indices(phi).rank == len(names)
    assert observability_indices(full).rank < len(all_names)


# -- estimation ----------------------------------------------------------------------------
def test_kabsch_and_base_registration(presets):
    rng = np.random.default_rng(3)
    P = rng.normal(0, 100, (10, 3))
    T = tf.pose_to_matrix([100, -20, 900], [0.3, -1.0, 2.0])
    np.testing.assert_allclose(tf.kabsch(P, tf.transform_points(T, P)), T, atol=1e-9)
    nominal = presets["educational_6r"]
    true = nominal.copy()
    true.base = T
    meas = simulate_measurements(true, 10, sigma_mm=0.0, rng=1)
    np.testing.assert_allclose(register_base(nominal, meas).base, T, atol=1e-9)


def test_noise_free_data_are_fitted_exactly_from_a_far_start(presets):
    nominal = presets["ur5"]
    true = perturbed_model(nominal, 5, length_mm=5.0, angle_deg=1.0, base_xyz=(2000, -1500, 3000),
                           base_rpy_deg=(60, -35, 40), target_mm=5.0)
    meas = simulate_measurements(true, 40, sigma_mm=0.0, rng=6)
    result = identify(nominal, meas)
    assert result.converged and result.after.rms_mm < 1e-6 and result.before.rms_mm > 5.0
    Q = random_configurations(nominal, 50, seed=9)
    names = ["marker"] * 50
    err = predict_points(result.model, Q, names) - predict_points(true, Q, names)
    assert np.abs(err).max() < 1e-5


def equivalent_truth(nominal, true, fixed=()):
    """The true robot expressed in the estimated parameters: a noise-free fit on many poses."""
    return identify(nominal, simulate_measurements(true, 300, sigma_mm=0.0, rng=99), fixed=fixed).model


# Largest |d − true d| of the joints on parallel axes (Hayati), measured over 8 seeds of the
# true robot and the noise (60 poses, σ = 0.05 mm): 6R 0.036, PUMA 0.16, UR5 0.023,
# ABB 0.069 mm; the bound is about 2x that (a blow-up would be metres).
PARALLEL_D_MM = {"educational_6r": 0.08, "puma560": 0.3, "ur5": 0.05, "abb_irb120": 0.15}


@pytest.mark.parametrize("name", PRESETS)
def test_noisy_fit_is_consistent_with_its_uncertainty(presets, name):
    nominal = presets[name]
    true = perturbed_model(nominal, 11)
    sigma = 0.05
    meas = simulate_measurements(true, 60, sigma_mm=sigma, rng=12)
    result = identify(nominal, meas)
    ref = equivalent_truth(nominal, true)
    params = result.identifiability.free
    err = parameter_difference(result.model, ref, params)
    z = np.abs(err) / result.estimate_std
    assert z.max() < 4.5, params[int(np.argmax(z))].name
    assert result.sigma_hat == pytest.approx(sigma, rel=0.2)
    assert result.after.rms_mm == pytest.approx(sigma * math.sqrt(3), rel=0.25)
    # Hayati: no blow-up of d on the parallel axes
    parallel = sorted({k for i in hayati_joints(nominal) for k in (i, i + 1)})
    assert parallel
    for i in parallel:
        assert abs(result.model.joints[i].d - ref.joints[i].d) < PARALLEL_D_MM[name], f"J{i + 1}.d"
    # the correlation matrix is a correlation matrix
    C = result.correlation
    assert np.allclose(np.diag(C), 1.0) and np.all(np.abs(C) <= 1 + 1e-9) and np.allclose(C, C.T)
    assert result.rank == len(result.estimated) and math.isfinite(result.condition_number)


def test_cost_per_iteration_decreases_and_result_is_drawable(presets):
    nominal = presets["educational_6r"]
    meas = simulate_measurements(perturbed_model(nominal, 2), 40, rng=3)
    result = identify(nominal, meas)
    fit_costs = [r.cost for r in result.iterations if r.stage == "fit"]
    assert all(b <= a for a, b in zip(fit_costs, fit_costs[1:]))
    assert result.n_iterations >= 2 and result.iterations[0].start
    rows = {r.name: r for r in result.parameters}
    assert len(rows) == len(all_parameters(nominal, ["marker"]))
    assert rows["J2.a"].identifiable and rows["J2.a"].std > 0 and rows["J2.a"].unit == "mm"
    assert rows["J2.theta"].unit == "deg" and rows["J2.theta"].nominal == pytest.approx(90.0)
    assert not rows["J1.theta"].identifiable and rows["J1.theta"].std is None
    assert rows["J1.theta"].explanation.startswith("J1.theta cannot be told apart from")
    assert rows["base.z"].identified == pytest.approx(result.model.base[2, 3])
    assert len(result.before.per_pose()) == 40 and result.before.rms_mm > result.after.rms_mm
    assert result.correlation.shape == (len(result.estimated),) * 2
    summary = result.summary()
    for key in ("rms_before_mm", "rms_after_mm", "iterations", "rank", "unidentifiable",
                "condition_number", "parameters"):
        assert key in summary
    assert summary["parameters"]["J2.a"]["std"] == rows["J2.a"].std


def test_pure_gauss_newton_gives_the_same_answer(presets):
    nominal = presets["abb_irb120"]
    meas = simulate_measurements(perturbed_model(nominal, 4), 40, rng=5)
    lm = identify(nominal, meas)
    gn = identify(nominal, meas, damping=0.0)
    assert all(r.damping == 0.0 for r in gn.iterations)
    assert gn.after.rms_mm == pytest.approx(lm.after.rms_mm, rel=1e-6)


def test_holdout_and_kfold_validation(presets):
    nominal = presets["educational_6r"]
    meas = simulate_measurements(perturbed_model(nominal, 2), 40, rng=4)
    r = identify(nominal, meas, holdout=0.25, seed=3)
    v = r.validation
    assert v.method == "holdout" and len(v.test_poses) == 10 and r.n_poses == 30
    assert v.before.rms_mm > 10 * v.after.rms_mm and v.after.n == 10
    assert identify(nominal, meas, holdout=0.25, seed=3).validation.test_poses == v.test_poses
    k = identify(nominal, meas, kfold=4, seed=1)
    assert k.validation.method == "kfold" and k.validation.after.n == 40 and len(k.validation.fold_rms_mm) == 4
    assert k.n_poses == 40 and k.validation.after.rms_mm < 0.2
    train, test = split_poses(range(20), 0.25, seed=0)
    assert len(test) == 5 and sorted(train + test) == list(range(20))
    folds = kfold_poses(range(10), 3, seed=0)
    assert sorted(sum(folds, [])) == list(range(10))
    with pytest.raises(UsageError):
        identify(nominal, meas, holdout=0.2, kfold=3)


def test_huber_flags_and_downweights_outliers(presets):
    nominal = presets["educational_6r"]
    true = perturbed_model(nominal, 3)
    meas = simulate_measurements(true, 50, rng=2)
    meas.xyz[[3, 17, 30]] += [[5, 0, 0], [0, -8, 2], [0, 0, 3]]
    plain = identify(nominal, meas)
    assert plain.outliers == [3, 17, 30]                 # flagged even without Huber
    robust = identify(nominal, meas, huber=3.0)
    assert robust.outliers == [3, 17, 30] and np.all(robust.weights[[3, 17, 30]] < 0.1)
    clean = np.delete(np.arange(50), [3, 17, 30])
    ref = identify(nominal, meas.subset(clean))
    Q = random_configurations(nominal, 30, seed=1)
    names = ["marker"] * 30

    def worst(model):
        return np.abs(predict_points(model, Q, names) - predict_points(ref.model, Q, names)).max()

    assert worst(robust.model) < 0.3 * worst(plain.model)
    assert robust.sigma_hat < 0.08 < plain.sigma_hat
    assert any(r.stage.startswith("huber") for r in robust.iterations)


def test_sigma_columns_weight_the_fit(presets):
    nominal = presets["puma560"]
    meas = simulate_measurements(perturbed_model(nominal, 2), 40, sigma_mm=0.05, rng=8, with_sigma=True)
    result = identify(nominal, meas)
    assert result.sigma_hat == pytest.approx(1.0, rel=0.25)   # unit weight: the sigmas are right


def test_user_fixed_parameter_keeps_its_nominal_value(presets):
    nominal = presets["educational_6r"]
    meas = simulate_measurements(perturbed_model(nominal, 2), 40, rng=8)
    result = identify(nominal, meas, fixed=["J3.a", "J4.theta"])
    assert result.model.joints[2].a == nominal.joints[2].a
    assert result.row("J4.theta").status == FIXED_BY_USER and result.row("J4.theta").std is None
    assert result.summary()["fixed"] == ["J3.theta", "J3.a"][1:] + ["J4.theta"]


# -- bad data ------------------------------------------------------------------------------
def test_too_few_poses(presets):
    nominal = presets["educational_6r"]
    meas = simulate_measurements(perturbed_model(nominal, 2), 5, rng=1)
    with pytest.raises(RoboCalError, match=r"too few measurements: 5 points give 15 equations .*Measure at least \d+ poses \(now 5\)"):
        identify(nominal, meas)


def test_degenerate_poses_say_which_joints_to_move(presets):
    nominal = presets["educational_6r"]
    true = perturbed_model(nominal, 2)
    Q = random_configurations(nominal, 40, seed=1)
    Q[:, 3], Q[:, 4] = 0.3, 0.5
    meas = simulate_measurements(true, 40, Q=Q, rng=1)
    with pytest.raises(RoboCalError) as err:
        identify(nominal, meas)
    msg = err.value.message
    assert "the measured poses cannot determine" in msg and "rank" in msg
    assert "J4 0.0 deg" in msg and "J5 0.0 deg" in msg and "more poses like these will not help" in msg
    Q[:, :] = 0.3
    with pytest.raises(RoboCalError, match="lie on a line"):
        identify(nominal, simulate_measurements(true, 40, Q=Q, rng=1))


def test_targets_measured_and_unmeasured(presets):
    nominal = presets["educational_6r"].copy()
    nominal.targets["probe"] = np.array([0.0, 30.0, 60.0])
    true = perturbed_model(nominal, 2)
    meas = simulate_measurements(true, 40, rng=1, targets=["marker"])
    result = identify(nominal, meas)         # probe never measured: fine, just not identified
    assert "probe.x" not in {r.name for r in result.parameters}
    assert np.array_equal(result.model.targets["probe"], nominal.targets["probe"])
    assert any("probe" in w for w in result.warnings)
    both = simulate_measurements(true, 30, rng=1, targets=["marker", "probe"])
    r2 = identify(nominal, both)
    assert {"probe.x", "marker.x"} <= set(r2.estimated) and r2.n_points == 60
    other = presets["educational_6r"]        # has no 'probe': estimated from the tool origin, and said so
    r3 = identify(other, both)
    assert "probe.x" in r3.estimated and "probe" not in other.targets
    assert any("probe are not in the robot file" in w for w in r3.warnings)


def test_divergence_is_reported(presets):
    nominal = presets["educational_6r"]
    wrong = nominal.copy()
    wrong.joints[1].a = 400.0          # a robot model that does not belong to the data
    wrong.joints[3].d = -300.0
    meas = simulate_measurements(perturbed_model(nominal, 2), 40, rng=1)
    with pytest.raises(RoboCalError, match="diverged|did not converge"):
        identify(wrong, meas)


# -- progress, cancel, files ---------------------------------------------------------------
def test_progress_and_cancel(presets):
    nominal = presets["educational_6r"]
    meas = simulate_measurements(perturbed_model(nominal, 2), 30, rng=1)
    seen = []
    identify(nominal, meas, progress=lambda f, m: seen.append(f), kfold=3)
    assert seen and all(0.0 <= f <= 1.0 for f in seen) and seen == sorted(seen) and seen[-1] == pytest.approx(1.0)
    calls = []

    def cancelled():
        calls.append(1)
        return len(calls) > 3

    with pytest.raises(Cancelled):
        identify(nominal, meas, cancelled=cancelled)


def test_calibrated_model_file(tmp_path, presets):
    nominal = presets["puma560"]
    true = perturbed_model(nominal, 2)
    meas = simulate_measurements(true, 40, rng=1)
    write_measurements(meas, tmp_path / "m.csv")
    result = identify_files(robot_path("puma560"), tmp_path / "m.csv", tmp_path / "cal.json", holdout=0.25)
    back = read_robot(tmp_path / "cal.json")
    cal = back.calibration
    assert cal["measurements"] == "m.csv" and cal["date"]
    assert cal["statistics"]["rms_after_mm"] == pytest.approx(result.after.rms_mm)
    assert cal["statistics"]["validation"]["method"] == "holdout"
    rows = {r["name"]: r for r in cal["parameters"]}
    assert rows["J2.a"]["std"] > 0 and rows["J1.theta"]["identifiable"] is False
    assert any(u["name"] == "J1.theta" for u in cal["unidentifiable"])
    Q = random_configurations(nominal, 20, seed=2)
    np.testing.assert_allclose(back.target_positions(Q, "marker"), result.model.target_positions(Q, "marker"),
                               atol=1e-9)
    # a calibrated model is a valid input: re-identification starts from it
    again = identify(back, meas.select_poses(range(40)))
    assert again.after.rms_mm <= result.after.rms_mm * 1.1
    assert error_stats(back, meas).rms_mm < 0.2
    assert evaluate(nominal, meas, register=True).rms_mm > 1.0
    # writing again replaces the file atomically
    write_calibrated_model(result, tmp_path / "cal.json")
    assert [p.name for p in tmp_path.iterdir() if p.name.startswith(".")] == []


def test_check_data_returns_indices(presets):
    nominal = presets["educational_6r"]
    ident = analyse(nominal, ["marker"])
    Q = random_configurations(nominal, 30, seed=4)
    obs = check_data(nominal, Q, ["marker"] * 30, ident)
    assert obs.rank == len(ident.free) and obs.o1 > 0 and obs.n_points == 30


def test_sigma_hat_is_unitless_when_the_measurements_carry_sigmas(presets):
    nominal = presets["educational_6r"]
    true = perturbed_model(nominal, 4)
    plain = identify(nominal, simulate_measurements(true, 40, sigma_mm=0.05, rng=1))
    weighted = identify(nominal, simulate_measurements(true, 40, sigma_mm=0.05, rng=1, with_sigma=True))
    assert not plain.weighted and "mm per axis" in plain.sigma_hat_text
    assert plain.sigma_hat == pytest.approx(0.05, rel=0.25)
    assert weighted.weighted and "own σ" in weighted.sigma_hat_text
    assert weighted.sigma_hat == pytest.approx(1.0, rel=0.25)          # the given sigmas were right
    assert weighted.calibration_section()["statistics"]["sigma_hat_unit"] == "1"
