"""SSD correspondence along the epipolar line (eq. 26–27), its reliability and the window sweep."""
from __future__ import annotations

import cv2
import numpy as np
import pytest

from core.camera import CameraModel
from core.marker.correspondence import find_disparity, plane_disparity_ratio, window_sweep
from core.stereo.rectification import StereoRectification
from core.stereo.rig import StereoRig

W, H = 640, 480
F = 800.0
B = 100.0


@pytest.fixture(scope="module")
def rect():
    """An ideal rectified pair: rectified pixels are raw pixels."""
    K = np.array([[F, 0, 319.5], [0, F, 239.5], [0, 0, 1]])
    cam = CameraModel(K, np.zeros(5), W, H)
    rig = StereoRig(cam, cam, np.eye(3), [-B, 0, 0])
    P1 = np.hstack([K, np.zeros((3, 1))])
    P2 = P1.copy()
    P2[0, 3] = -F * B
    return StereoRectification(rig, np.eye(3), np.eye(3), P1, P2)


def texture(seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    img = cv2.GaussianBlur(rng.normal(0, 1, (H, W)).astype(np.float32), (0, 0), 2.0)
    img = 128 + 60 * img / img.std()
    return img.astype(np.float32)


def shifted(img: np.ndarray, dx: float) -> np.ndarray:
    """The image content moved by dx px to the right (sub-pixel, bicubic)."""
    M = np.array([[1, 0, dx], [0, 1, 0]], np.float32)
    return cv2.warpAffine(img, M, (W, H), flags=cv2.INTER_CUBIC, borderMode=cv2.BORDER_REFLECT)


def u8(img):
    return np.clip(np.rint(img), 0, 255).astype(np.uint8)


@pytest.mark.parametrize("d0", [57.3, 120.75, 8.5])
def test_sub_pixel_disparity_and_a_unique_minimum(rect, d0):
    left = texture()
    right = shifted(left, -d0)          # a point at u_l is at u_l - d0 on the right
    c = find_disparity(rect, u8(left), u8(right), (320.0, 240.0), window=(31, 31))
    assert c.ok, c.reason
    assert abs(c.disparity - d0) < 0.05
    assert c.reliability < 0.2 and c.mismatch < 0.05
    # the curve for plotting: one value per integer disparity over the row, minimum near d0
    assert len(c.disparities) == len(c.criteria) > 500 and np.all(np.diff(c.disparities) == 1)
    assert abs(c.disparities[np.argmin(c.criteria)] - d0) <= 1
    assert c.criteria.min() == pytest.approx(c.plain_minimum)
    np.testing.assert_allclose(c.right_point, [320.0 - c.disparity, 240.0])
    assert 0 < c.sigma_disparity < 0.05


def test_repeated_pattern_is_ambiguous(rect):
    base = texture(1)
    tile = base[:, :80]
    left = np.tile(tile, (1, W // 80 + 1))[:, :W]      # period 80 px along the rows
    right = shifted(left, -30.0)
    c = find_disparity(rect, u8(left), u8(right), (320.0, 240.0), window=(31, 31))
    assert not c.ok and "ambiguous" in c.reason
    assert c.reliability > 0.6
    # accepting any ratio, the best of the equal minima is one of the pattern's copies, d ≡ 30 (mod 80);
    # a copy at d ≤ 0 is then refused for its sign
    copy = find_disparity(rect, u8(left), u8(right), (320.0, 240.0), window=(31, 31), max_reliability=1.0)
    assert min((copy.disparity - 30.0) % 80.0, 80.0 - (copy.disparity - 30.0) % 80.0) < 0.1
    assert copy.ok == (copy.disparity > 0) and (copy.ok or "≤ 0" in copy.reason)


def test_disparity_not_positive_is_refused(rect):
    left = texture(2)
    right = shifted(left, +25.0)        # the right view shows the content further right: d = -25
    c = find_disparity(rect, u8(left), u8(right), (300.0, 240.0), window=(31, 31))
    assert not c.ok and "≤ 0" in c.reason
    assert abs(c.disparity + 25.0) < 0.1


def test_no_match_in_the_right_image(rect):
    left = texture(3)
    right = texture(4)                  # another scene: nothing matches
    c = find_disparity(rect, u8(left), u8(right), (320.0, 240.0), window=(41, 41), max_reliability=1.0)
    assert not c.ok and "no good match" in c.reason


def test_window_leaving_the_image(rect):
    img = u8(texture())
    c = find_disparity(rect, img, img, (5.0, 240.0), window=(31, 31))
    assert not c.ok and "leaves the left image" in c.reason


def test_plane_warped_refinement_on_a_slanted_surface(rect):
    """A plane whose disparity grows across the window: the plain SSD is biased, the warped one not."""
    left = texture(5)
    # disparity d(x) = 60 + 0.08 (x - 320): right(x_r) = left(x_l) with x_r = x_l - d(x_l)
    xl = np.arange(W, dtype=np.float64)
    xr = xl - (60 + 0.08 * (xl - 320))
    # invert the monotonic map: for each right column, the left column that lands there
    src = np.interp(np.arange(W), xr, xl).astype(np.float32)
    map_x = np.tile(src, (H, 1))
    map_y = np.tile(np.arange(H, dtype=np.float32)[:, None], (1, W))
    right = cv2.remap(left, map_x, map_y, cv2.INTER_CUBIC, borderMode=cv2.BORDER_REFLECT)
    # the plane with 1/Z ∝ disparity: n·K⁻¹(x, y, 1) ∝ 60 + 0.08 (x − 320)
    K = rect.P1[:3, :3]
    n = np.array([0.08, 0.0, 60 - 0.08 * 320]) @ K          # (n K^-1) (x, y, 1) = 0.08 x + 60 - 25.6
    X, Y = np.meshgrid([300.0, 320.0, 340.0], [240.0])
    np.testing.assert_allclose(plane_disparity_ratio(n, K, X, Y, 320.0, 240.0)[0], [58.4 / 60, 1.0, 61.6 / 60])
    warped = find_disparity(rect, u8(left), u8(right), (320.0, 240.0), window=(61, 61), plane_normal=n,
                            disparity_guess=60.0)
    assert warped.ok and warped.warped
    assert abs(warped.disparity - 60.0) < 0.05
    assert warped.minimum < 0.5 * warped.plain_minimum
    assert len(warped.refined_disparities) == len(warped.refined_criteria) > 3


def test_window_sweep_sizes_5_to_37(rect):
    left = texture(6)
    right = shifted(left, -40.0)
    sweep = window_sweep(rect, u8(left), u8(right), (320.0, 240.0))
    np.testing.assert_array_equal(sweep.sizes, np.arange(5, 38, 2))
    assert np.all(np.isfinite(sweep.minima)) and np.all(sweep.minima >= 0)
    assert np.all(np.abs(sweep.disparities - 40.0) < 0.3)
    assert sweep.reliabilities.shape == sweep.sizes.shape
