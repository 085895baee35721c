"""Triangulation (eq. 22–25) against exact projections, OpenCV's Q matrix and Monte Carlo."""
import cv2
import numpy as np
import pytest

from core.camera import CameraModel
from core.errors import RoboCalError
from core.stereo.rig import StereoRig
from core.transforms import rot_x, rot_y
from core.marker.triangulation import triangulate_general, triangulate_linear, triangulate_rectified

SIZE = (1280, 1024)


def _rig(distorted=True) -> StereoRig:
    d1 = [-0.08, 0.05, 0.0004, -0.0002, 0.0] if distorted else [0] * 5
    d2 = [-0.075, 0.045, -0.0003, 0.0001, 0.0] if distorted else [0] * 5
    left = CameraModel([[1500, 0, 643.0], [0, 1500, 509.0], [0, 0, 1]], d1, *SIZE)
    right = CameraModel([[1495, 0, 637.0], [0, 1496, 514.0], [0, 0, 1]], d2, *SIZE)
    return StereoRig(left, right, rot_y(np.deg2rad(0.3)) @ rot_x(np.deg2rad(-0.2)), [-130.0, 0.8, 1.1])


def _rectify(rig):
    return cv2.stereoRectify(rig.left.K, rig.left.dist, rig.right.K, rig.right.dist, SIZE,
                             rig.R, rig.T.reshape(3, 1), flags=cv2.CALIB_ZERO_DISPARITY, alpha=0)


POINTS = np.array([[0.0, 0.0, 600.0], [-120.0, 80.0, 450.0], [150.0, -90.0, 880.0], [30.0, 140.0, 700.0]])


def test_general_triangulation_recovers_exact_points():
    rig = _rig()
    uv_l, uv_r = rig.project(POINTS)
    np.testing.assert_allclose(triangulate_linear(rig, uv_l, uv_r), POINTS, atol=1e-6)
    for p, a, b in zip(POINTS, uv_l, uv_r):
        result = triangulate_general(rig, a, b)
        np.testing.assert_allclose(result.point, p, atol=1e-7)
        assert result.reprojection_px < 1e-8


def test_rectified_triangulation_matches_opencv_Q():
    rig = _rig()
    R1, R2, P1, P2, Q, _, _ = _rectify(rig)
    for p in POINTS:
        uv_l, uv_r = rig.project(p[None])
        rl = cv2.undistortPoints(uv_l.reshape(1, 1, 2), rig.left.K, rig.left.dist, R=R1, P=P1).reshape(2)
        rr = cv2.undistortPoints(uv_r.reshape(1, 1, 2), rig.right.K, rig.right.dist, R=R2, P=P2).reshape(2)
        assert abs(rl[1] - rr[1]) < 1e-6  # same row after rectification
        disparity = rl[0] - rr[0]
        result = triangulate_rectified(rl[0], rl[1], disparity, P1, P2, R1)
        np.testing.assert_allclose(result.point, p, atol=1e-6)
        h = Q @ np.array([rl[0], rl[1], disparity, 1.0])
        np.testing.assert_allclose(R1.T @ (h[:3] / h[3]), p, atol=1e-6)


def test_predicted_uncertainty_matches_monte_carlo():
    rig = _rig(distorted=False)
    R1, R2, P1, P2, Q, _, _ = _rectify(rig)
    p = np.array([40.0, -30.0, 750.0])
    uv_l, uv_r = rig.project(p[None])
    rl = cv2.undistortPoints(uv_l.reshape(1, 1, 2), rig.left.K, rig.left.dist, R=R1, P=P1).reshape(2)
    rr = cv2.undistortPoints(uv_r.reshape(1, 1, 2), rig.right.K, rig.right.dist, R=R2, P=P2).reshape(2)
    sigma = 0.1
    rng = np.random.default_rng(7)
    samples = []
    for _ in range(4000):
        nl, nr = rng.normal(0, sigma, 2), rng.normal(0, sigma, 1)
        samples.append(triangulate_rectified(rl[0] + nl[0], rl[1] + nl[1], (rl[0] + nl[0]) - (rr[0] + nr[0]),
                                             P1, P2, R1).point)
    empirical = np.std(samples, axis=0)
    predicted = triangulate_rectified(rl[0], rl[1], rl[0] - rr[0], P1, P2, R1, sigma_px=sigma).sigma
    np.testing.assert_allclose(empirical, predicted, rtol=0.1)
    general = triangulate_general(rig, uv_l[0], uv_r[0], sigma_px=sigma)
    np.testing.assert_allclose(general.sigma[2], predicted[2], rtol=0.15)


def test_non_positive_disparity_is_refused():
    rig = _rig()
    R1, R2, P1, P2, Q, _, _ = _rectify(rig)
    with pytest.raises(RoboCalError, match="disparity"):
        triangulate_rectified(600.0, 500.0, -3.0, P1, P2, R1)
