"""Camera model (eq. 11–19) against OpenCV, and its inverse."""
import cv2
import numpy as np
from hypothesis import given, settings, strategies as st

from core.camera import CameraModel
from core.stereo.rig import StereoRig
from core.transforms import rot_y

K = np.array([[1502.3, 0.0, 641.7], [0.0, 1499.1, 509.2], [0.0, 0.0, 1.0]])


@settings(max_examples=60, deadline=None)
@given(k1=st.floats(-0.4, 0.4), k2=st.floats(-0.3, 0.3), p1=st.floats(-0.01, 0.01),
       p2=st.floats(-0.01, 0.01), k3=st.floats(-0.2, 0.2), seed=st.integers(0, 1000))
def test_projection_agrees_with_opencv(k1, k2, p1, p2, k3, seed):
    dist = np.array([k1, k2, p1, p2, k3])
    camera = CameraModel(K, dist)
    rng = np.random.default_rng(seed)
    points = rng.uniform([-300, -250, 350], [300, 250, 1100], (200, 3))
    rvec, tvec = rng.normal(0, 0.2, 3), rng.normal(0, 20, 3)
    R, _ = cv2.Rodrigues(rvec)
    expected, _ = cv2.projectPoints(points, rvec, tvec, K, dist)
    expected = expected.reshape(-1, 2)
    # the 1e-9 px agreement holds where pixels mean something: around the 1280x1024 image (far
    # outside it the distortion polynomial reaches 1e6 px and only relative rounding is left)
    near = np.all(np.abs(expected - [640, 512]) < 5000, axis=1)
    np.testing.assert_allclose(camera.project_from(points, R, tvec)[near], expected[near], atol=1e-9, rtol=0)
    np.testing.assert_allclose(camera.project_from(points, R, tvec), expected, atol=1e-9, rtol=1e-13)
    assert near.sum() >= 100


def test_undistortion_inverts_projection():
    camera = CameraModel(K, [-0.2, 0.08, 0.001, -0.0007, -0.01])
    rng = np.random.default_rng(3)
    points = rng.uniform([-250, -200, 400], [250, 200, 900], (500, 3))
    rays = camera.pixel_rays(camera.project(points))
    expected = points / np.linalg.norm(points, axis=1, keepdims=True)
    np.testing.assert_allclose(rays, expected, atol=1e-10)


def test_scaled_camera_keeps_pixel_centres():
    camera = CameraModel(K, [-0.1, 0.02, 0, 0, 0])
    fine = camera.scaled(3)
    points = np.array([[10.0, -20.0, 600.0], [-150.0, 90.0, 800.0]])
    uv, uv_fine = camera.project(points), fine.project(points)
    np.testing.assert_allclose(uv_fine, 3 * uv + 1.0, atol=1e-9)  # centre of a 3x3 block
    assert fine.size == (3840, 3072)


def test_stereo_rig_geometry_matches_opencv_conventions():
    left = CameraModel(K)
    right = CameraModel(K)
    R = rot_y(np.deg2rad(0.4))
    T = np.array([-130.0, 0.5, -1.0])
    rig = StereoRig(left, right, R, T)
    assert abs(rig.baseline - np.linalg.norm(T)) < 1e-12
    np.testing.assert_allclose(rig.to_right(rig.right_centre[None])[0], 0.0, atol=1e-12)
    points = np.random.default_rng(0).uniform([-200, -200, 500], [200, 200, 900], (50, 3))
    uv_l, uv_r = rig.project(points)
    F = rig.fundamental()
    hl = np.c_[uv_l, np.ones(50)]
    hr = np.c_[uv_r, np.ones(50)]
    assert np.max(np.abs(np.sum(hr @ F * hl, axis=1))) < 1e-9  # x_r^T F x_l = 0


def test_rational_model_agrees_with_opencv_and_inverts():
    dist = np.array([-0.28, 0.12, 0.0005, -0.0003, 0.01, 0.15, -0.05, 0.02])   # k1 k2 p1 p2 k3 k4 k5 k6
    camera = CameraModel(K, dist)
    assert camera.dist.size == 8
    rng = np.random.default_rng(4)
    points = rng.uniform([-250, -200, 400], [250, 200, 900], (300, 3))
    expected, _ = cv2.projectPoints(points, np.zeros(3), np.zeros(3), K, dist)
    np.testing.assert_allclose(camera.project(points), expected.reshape(-1, 2), atol=1e-9)
    without = CameraModel(K, dist[:5]).project(points)
    assert np.abs(without - expected.reshape(-1, 2)).max() > 1.0       # k4..k6 matter
    rays = camera.pixel_rays(camera.project(points))
    np.testing.assert_allclose(rays, points / np.linalg.norm(points, axis=1, keepdims=True), atol=1e-10)
    assert CameraModel(K, np.r_[dist[:5], 0, 0, 0]).dist.size == 5     # zero k4..k6: the 5-term model
