"""The predicted error per point from a calibration's parameter covariance."""
import numpy as np
import pytest

from core.compensation.prediction import predicted_error
from core.errors import RoboCalError
from core.kinematics.jacobian import all_parameters
from core.monitoring.uncertainty import CalibrationUncertainty, norm_limit, prediction_covariance
from core.robot.file import read_robot
from core.robot.model import robot_path


def _uncertainty(model, seed=0):
    params = all_parameters(model, ["marker"])
    rng = np.random.default_rng(seed)
    A = rng.normal(0.0, 1.0, (len(params), len(params)))
    scale = np.array([1e-4 if p.angular else 0.02 for p in params])      # rad, mm
    C = (A @ A.T / len(params)) * np.outer(scale, scale)
    return CalibrationUncertainty(params, C, sigma_mm=0.05)


def test_covariance_matches_the_monitoring_prediction_without_the_camera_noise():
    model = read_robot(robot_path("educational_6r"))
    unc = _uncertainty(model)
    lo, hi = model.sampling_range()
    Q = lo + (hi - lo) * np.random.default_rng(1).random((6, 6))
    pred = predicted_error(model, Q, "marker", uncertainty=unc)
    S = prediction_covariance(model, unc, Q, ["marker"] * 6)
    for i in range(6):
        block = S[3 * i:3 * i + 3, 3 * i:3 * i + 3] - unc.sigma_mm ** 2 * np.eye(3)
        assert np.allclose(pred.covariance[i], block, rtol=1e-9, atol=1e-15)
        assert pred.sigma_mm[i] == pytest.approx(np.sqrt(np.trace(block)), rel=1e-9)
        # the 95 % length from the table, against the exact weighted-χ² quantile
        assert pred.limit_mm[i] == pytest.approx(norm_limit(block, 0.95), rel=3e-3)
    assert pred.probability == 0.95
    assert np.all(pred.limit_mm > pred.sigma_mm)


def test_tool_frame_point_has_no_marker_parameters():
    model = read_robot(robot_path("educational_6r"))
    unc = _uncertainty(model)
    Q = np.zeros((1, 6))
    tool = predicted_error(model, Q, "tool", uncertainty=unc)
    # the tool frame's origin is a point the marker offsets do not move: its covariance is the
    # one of a target at the origin with the marker rows and columns of C removed
    keep = [k for k, p in enumerate(unc.parameters) if p.group != "target"]
    reduced = CalibrationUncertainty([unc.parameters[k] for k in keep], unc.covariance[np.ix_(keep, keep)], 0.05)
    at_origin = model.copy()
    at_origin.targets = {"marker": np.zeros(3)}
    expected = predicted_error(at_origin, Q, "marker", uncertainty=reduced)
    assert np.allclose(tool.covariance, expected.covariance, rtol=1e-9)


def test_many_points_and_none():
    model = read_robot(robot_path("ur5"))
    unc = _uncertainty(model, seed=3)
    lo, hi = model.sampling_range()
    Q = lo + (hi - lo) * np.random.default_rng(2).random((3000, 6))
    pred = predicted_error(model, Q, uncertainty=unc)
    assert pred.sigma_mm.shape == pred.limit_mm.shape == (3000,)
    for i in (0, 1234, 2999):
        assert pred.limit_mm[i] == pytest.approx(norm_limit(pred.covariance[i], 0.95), rel=3e-3)
    assert len(predicted_error(model, np.zeros((0, 6)), uncertainty=unc).sigma_mm) == 0


def test_an_uncalibrated_robot_file_is_refused():
    model = read_robot(robot_path("ur5"))
    with pytest.raises(RoboCalError, match="holds no calibration"):
        predicted_error(model, np.zeros((1, 6)))
