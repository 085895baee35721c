import numpy as np
import pytest

from core.errors import RoboCalError, UsageError
from core.measurement.file import Measurements
from core.monitoring.check import run_check
from core.monitoring.diagnosis import BASE, JOINT, NONE, SEVERAL, TOOL, diagnose
from core.monitoring.reidentify import propose_poses, reidentify, write_reidentified
from core.monitoring.uncertainty import calibration_uncertainty
from core.robot.file import read_robot
from core.virtual_lab.changes import apply_change, parse_change
from core.virtual_lab.ideal_measurements import ideal_measure
from core.virtual_lab.synthetic import simulate_measurements
from tests.core.monitoring.cell import SIGMA, cell


def checked(change, seed=0):
    c = cell()
    c.reset()
    if change:
        apply_change(c.lab, change, seed=seed)
    try:
        result = run_check(c.model, c.unc, c.Q, ideal_measure(c.lab, sigma_mm=SIGMA, seed=50 + seed))
        return c, result, diagnose(c.model, c.unc, result)
    finally:
        pass


@pytest.mark.parametrize("change, kind, joint", [
    ("tool:1.5", TOOL, -1), ("base:2", BASE, -1), ("joint2:0.2", JOINT, 1), ("joint3:0.2", JOINT, 2),
    ("joint4:0.3", JOINT, 3), ("joint1:0.2", JOINT, 0),
])
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_each_change_is_detected_and_diagnosed(change, kind, joint, seed):
    c, result, diag = checked(change, seed)
    c.reset()
    assert not result.within
    assert diag.explained and diag.kind == kind and diag.chosen.joint == joint, diag.text


def test_tool_change_is_measured_in_words():
    c, result, diag = checked("tool:1.8", 0)
    c.reset()
    moved = c.lab.true_robot.targets["marker"]     # after reset: the calibrated truth
    assert diag.text.startswith("The marker moved 1.8 mm on the tool")
    assert "base and joints unchanged" in diag.text
    change = np.array([diag.chosen.change()[f"marker.{a}"] for a in "xyz"])
    apply_change(c.lab, "tool:1.8", seed=0)
    truth = c.lab.true_robot.targets["marker"] - moved
    c.reset()
    np.testing.assert_allclose(change, truth, atol=0.1)


def test_bent_link_is_not_a_simple_change():
    c, result, diag = checked("link3:1.0")
    c.reset()
    assert not result.within and diag.kind == SEVERAL and diag.full_calibration
    assert "full calibration" in diag.text


def test_no_change_is_diagnosed_as_none():
    c, result, diag = checked(None)
    assert result.within and diag.chosen.kind == NONE and not diag.full_calibration


@pytest.mark.parametrize("change", ["tool:1.5", "base:2", "joint3:0.3"])
def test_reidentification_from_a_few_poses_brings_the_error_back(tmp_path, change):
    c, result, diag = checked(change, 4)
    try:
        proposal = propose_poses(c.model, c.unc, diag.parameters, result.Q, candidates=500, **c.options)
        assert len(proposal.Q) <= 2 * len(diag.parameters)
        new = simulate_measurements(c.lab.true_robot, len(proposal.Q), Q=proposal.Q, sigma_mm=SIGMA,
                                    targets=["marker"], rng=9)
        Q = np.vstack([new.Q, result.Q])
        meas = Measurements(pose=np.arange(len(Q)), target=["marker"] * len(Q), q_file=c.model.q_to_file(Q),
                            xyz=np.vstack([new.xyz, [p.measured for p in result.points]]), Q=Q)
        re = reidentify(c.model, c.unc, diag.parameters, meas, reason=diag.text, previous="calibrated.json")
        out = write_reidentified(re, tmp_path / "updated.json")
        model = read_robot(out)
        unc = calibration_uncertainty(model)
        after = run_check(model, unc, c.Q, ideal_measure(c.lab, sigma_mm=SIGMA, seed=77))
    finally:
        c.reset()
    assert not result.within and after.within
    assert after.rms_mm < 0.3 * result.rms_mm
    (entry,) = model.calibration["history"]
    assert entry["updated"] == "calibrated.json" and entry["changed"] == re.changed and entry["reason"] == diag.text


def test_failed_reidentification_writes_nothing(tmp_path):
    c, result, diag = checked("link3:1.0")
    try:
        tool = [p for p in c.unc.parameters if p.group == "target"]
        new = simulate_measurements(c.lab.true_robot, len(c.Q), Q=c.Q, sigma_mm=SIGMA, targets=["marker"], rng=9)
        (tmp_path / "updated.json").write_text("good")
        with pytest.raises(RoboCalError, match="full calibration"):
            write_reidentified(reidentify(c.model, c.unc, tool, new), tmp_path / "updated.json")
    finally:
        c.reset()
    assert (tmp_path / "updated.json").read_text() == "good"


def test_reidentify_requires_a_change():
    c = cell()
    meas = Measurements(pose=[0], target=["marker"], q_file=np.zeros((1, 6)), xyz=np.zeros((1, 3)))
    with pytest.raises(RoboCalError, match="nothing changed"):
        reidentify(c.model, c.unc, [], meas)


@pytest.mark.parametrize("text, kind, size, joint", [
    ("tool:1.5", "tool", 1.5, 0), ("base:2", "base", 2.0, 0), ("joint3:-0.4", "joint", -0.4, 3),
    ("LINK2:1", "link", 1.0, 2)])
def test_change_specifications(text, kind, size, joint):
    ch = parse_change(text, 6)
    assert (ch.kind, ch.size, ch.joint) == (kind, size, joint)


@pytest.mark.parametrize("text", ["tool", "tool:-1", "joint:1", "joint7:1", "tool3:1", "base:100", "bend:1"])
def test_bad_change_specifications(text):
    with pytest.raises(UsageError):
        parse_change(text, 6)


def test_change_moves_only_what_it_says():
    c = cell()
    c.reset()
    try:
        apply_change(c.lab, "joint2:0.5")
        changed = c.lab.true_robot
    finally:
        c.reset()
    assert np.rad2deg(changed.joints[1].theta - c.true.joints[1].theta) == pytest.approx(0.5)
    assert changed.joints[2].theta == c.true.joints[2].theta
    np.testing.assert_array_equal(changed.base, c.true.base)


# -- the absolute test: "several" fits, its outlying points set aside ---------------------------
def several_fit(c, result):
    """(e, L, whitened Jacobian of "several", its rank, σ̂'s degrees of freedom) of a check."""
    from scipy.linalg import cholesky, solve_triangular
    from core.kinematics.jacobian import calibration_jacobian
    from core.monitoring.diagnosis import candidate_sets
    from core.monitoring.uncertainty import prediction_covariance
    S = prediction_covariance(c.model, c.unc, result.Q, result.targets)
    L = cholesky(S, lower=True)
    (params,) = [p for kind, _, p, _ in candidate_sets(c.model, "marker") if kind == SEVERAL]
    Jw = solve_triangular(L, calibration_jacobian(c.model, result.Q, result.targets, params), lower=True)
    return result.residuals, L, Jw, int(np.linalg.matrix_rank(Jw / np.linalg.norm(Jw, axis=0))), c.unc.dof


def test_the_absolute_test_raises_false_alarms_at_alpha_under_gaussian_errors():
    """400 checks whose errors are exactly what the calibration predicts (e = s·L·z: Gaussian with
    covariance S, s² = ν/χ²_ν the scatter of its σ̂): unexplained at each α in about α of them."""
    from scipy.stats import binom
    from core.monitoring.diagnosis import absolute_test
    c, result, _ = checked(None)
    _, L, Jw, p, dof = several_fit(c, result)
    assert len(result.residuals) - p - 6 >= 3          # two points can be set aside: the robust form is tested
    rng = np.random.default_rng(2026)
    draws = 400
    probabilities = np.array([absolute_test(np.sqrt(dof / rng.chisquare(dof)) * L @ rng.standard_normal(len(L)),
                                            L, Jw, p, dof).probability for _ in range(draws)])
    for alpha in (0.01, 0.05, 0.2):
        low, high = binom.interval(0.998, draws, alpha)
        assert low <= np.count_nonzero(probabilities < alpha) <= high, (alpha, np.mean(probabilities < alpha))


def outlying(result, points, sizes):
    """The check with `points` measured `sizes` × the 3D σ (σ·√3) off, each in its own direction."""
    from dataclasses import replace
    directions = np.array([[1.0, 0.0, 0.0], [0.0, 0.6, 0.8], [0.0, -0.8, 0.6], [0.6, 0.0, -0.8]])
    for k, (i, size) in enumerate(zip(points, sizes)):
        point = result.points[i]
        result.points[i] = replace(point, measured=point.measured + size * SIGMA * np.sqrt(3) * directions[k])
    return result


@pytest.mark.parametrize("change, seed, kind", [("tool:1.5", 0, TOOL), ("tool:1.5", 3, TOOL), ("joint5:0.3", 0, JOINT)])
def test_two_outlying_points_do_not_make_a_simple_change_unexplained(change, seed, kind):
    """A simple change with two check points measured 4 and 5 × 3D σ off (image errors have heavy
    tails): "several" with every point fails the χ²/F test, but with its outlying points set aside
    it fits, so the change is named."""
    from scipy.stats import f as f_dist
    c, result, _ = checked(change, seed)
    c.reset()
    diag = diagnose(c.model, c.unc, outlying(result, [1, 5], [4.0, 5.0]))
    full = next(f for f in diag.fits if f.kind == SEVERAL)
    dof = full.n - full.p
    assert f_dist.sf(full.rss / dof, dof, c.unc.dof) < 1e-4           # every point counted: "unexplained"
    assert diag.explained and diag.kind == kind and not diag.full_calibration, diag.text
    assert diag.absolute.probability >= 0.05 and len(diag.absolute.set_aside) == 2
    assert diag.summary()["set_aside"] == diag.absolute.set_aside


def test_two_outlying_points_without_a_change_are_named_not_called_within():
    """No change, two check points measured 4 and 5 × 3D σ off: the check is out of limits at
    those two poses only and no change explains it, so the words name the two poses (never "the
    errors are within what the calibration predicts" beside a check out of limits)."""
    c, result, _ = checked(None, 0)
    c.reset()
    assert result.within
    result = outlying(result, [1, 5], [4.0, 5.0])
    out = [p for p in result.points if not p.within]
    assert [p.pose for p in out] == [result.points[1].pose, result.points[5].pose] and not result.within
    diag = diagnose(c.model, c.unc, result)
    assert diag.explained and diag.chosen.kind == NONE and not diag.full_calibration, diag.text
    assert diag.text.startswith("No change of the tool, the base or a joint's zero explains this check: only poses "
                                f"{out[0].pose} and {out[1].pose} are beyond their limit (by "
                                f"{out[0].error_mm - out[0].limit_mm:.3f}, {out[1].error_mm - out[1].limit_mm:.3f} mm)")
    assert "within what the calibration predicts" not in diag.text and "run the check again" in diag.text


def test_a_check_out_of_limits_only_as_a_whole_is_not_called_within():
    """Every point within its own limit but the RMS beyond the overall one, and no change chosen:
    the words say so, with the RMS and its limit."""
    from dataclasses import replace
    from core.monitoring.diagnosis import describe
    c, result, diag = checked(None, 0)
    c.reset()
    assert result.within and diag.chosen.kind == NONE
    over = replace(result, rms_mm=result.rms_limit_mm * 1.2)
    assert all(p.within for p in over.points) and not over.within
    text, full = describe(diag.chosen, True, c.model, over)
    assert text == ("No change of the tool, the base or a joint's zero explains this check: the errors are spread "
                    "over every pose, a little larger than the calibration predicts "
                    f"({over.rms_mm:.3f} mm RMS, limit {over.rms_limit_mm:.3f} mm). Run the check again; if it "
                    "stays out of limits, run a full calibration.") and not full
    assert describe(diag.chosen, True, c.model, result)[0] == diag.text == (
        "No change found: the errors are within what the calibration predicts.")


@pytest.mark.parametrize("change", ["link3:1.0", "link2:1"])
def test_a_bent_link_stays_unexplained_with_points_set_aside(change):
    c, result, diag = checked(change)
    c.reset()
    assert not diag.explained and diag.full_calibration and len(diag.absolute.set_aside) == 2
    assert diag.absolute.probability < diag.alpha
