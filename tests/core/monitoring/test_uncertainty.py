import json

import numpy as np
import pytest
from scipy.stats import chi2

from core.errors import RoboCalError
from core.monitoring.uncertainty import calibration_uncertainty, norm_limit, prediction_covariance
from core.robot.file import read_robot, robot_to_dict
from tests.core.monitoring.cell import cell


def test_calibrated_file_carries_the_covariance_of_the_estimated_parameters():
    c = cell()
    cov = c.model.calibration["covariance"]
    assert len(cov["parameters"]) == len(cov["matrix"]) == c.unc.covariance.shape[0] > 20
    assert "marker.x" in cov["parameters"] and "base.rz" in cov["parameters"]
    # the std of the parameter table is the square root of the diagonal (file units)
    row = next(r for r in c.model.calibration["parameters"] if r["name"] == "marker.x")
    k = cov["parameters"].index("marker.x")
    assert row["std"] == pytest.approx(np.sqrt(c.unc.covariance[k, k]), rel=1e-9)
    assert c.unc.sigma_mm == pytest.approx(c.model.calibration["statistics"]["sigma_hat"])


def test_isotropic_limit_is_the_chi_quantile():
    S = 0.04 * np.eye(3)
    assert norm_limit(S, 0.99) == pytest.approx(0.2 * np.sqrt(chi2.ppf(0.99, 3)), rel=1e-8)


def test_anisotropic_limit_matches_sampled_quantile():
    rng = np.random.default_rng(0)
    S = np.diag([0.01, 0.02, 0.09])
    x = rng.normal(size=(400_000, 3)) * np.sqrt(np.diag(S))
    sampled = np.quantile(np.linalg.norm(x, axis=1), 0.99)
    assert norm_limit(S, 0.99) == pytest.approx(sampled, rel=0.004)


def test_prediction_covariance_adds_the_model_part_to_the_noise():
    c = cell()
    S = prediction_covariance(c.model, c.unc, c.Q[:2], ["marker"] * 2)
    noise = c.unc.sigma_mm ** 2
    assert S.shape == (6, 6) and np.all(np.diag(S) > noise)
    assert np.all(np.diag(S) < 3 * noise)        # a 50-pose calibration predicts well
    assert abs(S[0, 3]) > 0                       # points share the model: correlated


@pytest.mark.parametrize("edit, field", [
    (lambda d: d.pop("calibration"), "calibration"),
    (lambda d: d["calibration"].pop("covariance"), "calibration.covariance"),
    (lambda d: d["calibration"]["covariance"]["parameters"].__setitem__(0, "J9.a"),
     "calibration.covariance.parameters"),
    (lambda d: d["calibration"]["covariance"]["matrix"][0].__setitem__(1, "x"), "calibration.covariance.matrix"),
    (lambda d: d["calibration"]["covariance"]["matrix"].pop(), "calibration.covariance.matrix"),
    (lambda d: d["calibration"]["statistics"].__setitem__("sigma_hat", -1), "calibration.statistics.sigma_hat"),
])
def test_bad_calibration_names_file_and_field(tmp_path, edit, field):
    data = robot_to_dict(cell().model)
    data = json.loads(json.dumps(data))
    edit(data)
    path = tmp_path / "calibrated.json"
    path.write_text(json.dumps(data))
    with pytest.raises(RoboCalError) as err:
        calibration_uncertainty(read_robot(path), source=path)
    assert err.value.source == str(path) and err.value.field == field
    assert str(path) in str(err.value)


def test_the_noise_of_a_weighted_calibration_is_its_own_error_in_mm():
    """σ̂ of a calibration that weighted its points is a factor: the noise is its RMS error per axis
    with the fitted parameters' share put back (0.0067 mm RMS over 30 points, 63 dof)."""
    from core.monitoring.uncertainty import statistics_sigma_mm
    stats = {"sigma_hat": 0.688, "sigma_hat_unit": "1", "rms_after_mm": 0.0067, "n_points": 30, "dof": 63}
    assert statistics_sigma_mm(stats) == pytest.approx(0.0067 / np.sqrt(3) * np.sqrt(90 / 63), rel=1e-12)
    stats["validation"] = {"after": {"rms_mm": 0.0095}}      # the held-out poses' error is larger: it counts
    assert statistics_sigma_mm(stats) == pytest.approx(0.0095 / np.sqrt(3), rel=1e-12)
    assert statistics_sigma_mm({"sigma_hat": 0.049}) == 0.049
    with pytest.raises(RoboCalError) as exc:
        statistics_sigma_mm({"sigma_hat": 0.7, "sigma_hat_unit": "1"}, "c.json")
    assert exc.value.field == "calibration.statistics.rms_after_mm"


@pytest.mark.parametrize("key, value, field", [("sigma_hat", 1e308, "calibration.statistics.sigma_hat"),
                                               ("covariance", 1e300, "calibration.covariance.matrix")])
def test_a_calibration_that_did_not_converge_is_refused(key, value, field):
    c = cell()
    data = json.loads(json.dumps(robot_to_dict(c.model)))
    if key == "sigma_hat":
        data["calibration"]["statistics"]["sigma_hat"] = value
    else:
        data["calibration"]["covariance"]["matrix"][0][0] = value
    from core.robot.file import robot_from_dict
    with pytest.raises(RoboCalError) as exc:
        calibration_uncertainty(robot_from_dict(data), source="c.json")
    assert exc.value.field == field


def test_a_point_with_its_own_covariance_keeps_its_shape_above_the_calibrations_noise():
    """Σ_i scaled by max(k², σ²/(tr Σ_i / 3)): a point measured less precisely than σ keeps its
    own covariance (times k² for a weighted calibration); one measured better is raised to σ²
    per axis on average, its shape kept; a point without one gets σ²·I."""
    from dataclasses import replace
    unc = replace(cell().unc, sigma_mm=0.01)
    wide = np.diag([0.01, 0.01, 0.06]) ** 2                 # mean per axis 0.0036 mm² > σ² = 1e-4
    np.testing.assert_allclose(unc.measurement_covariance(wide), wide, rtol=1e-12)
    np.testing.assert_allclose(replace(unc, noise_factor=1.5).measurement_covariance(wide), 2.25 * wide, rtol=1e-12)
    narrow = np.diag([0.001, 0.002, 0.005]) ** 2
    scaled = unc.measurement_covariance(narrow)
    assert np.trace(scaled) / 3 == pytest.approx(1e-4, rel=1e-12)
    np.testing.assert_allclose(scaled / scaled[2, 2], narrow / narrow[2, 2], rtol=1e-12)
    np.testing.assert_allclose(unc.measurement_covariance(None), 1e-4 * np.eye(3), rtol=1e-12)
    # S: the parameter part plus each point's block; the points' correlation through the model stays
    S0 = prediction_covariance(cell().model, unc, cell().Q[:2], ["marker"] * 2)
    S1 = prediction_covariance(cell().model, unc, cell().Q[:2], ["marker"] * 2, [wide, None])
    np.testing.assert_allclose(S1 - S0, np.block([[wide - 1e-4 * np.eye(3), np.zeros((3, 3))],
                                                  [np.zeros((3, 3)), np.zeros((3, 3))]]), atol=1e-15)


def test_the_noise_factor_is_a_weighted_calibrations_sigma_hat():
    from core.monitoring.uncertainty import statistics_noise_factor
    assert statistics_noise_factor({"sigma_hat": 0.688, "sigma_hat_unit": "1"}) == 0.688
    assert statistics_noise_factor({"sigma_hat": 0.049}) == 1.0                 # σ̂ in mm: not a factor
    assert statistics_noise_factor({"sigma_hat": "x", "sigma_hat_unit": "1"}) == 1.0
