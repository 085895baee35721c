"""The marker in 3D from a stereo pair, the per-pose rejections, and tracking mode."""
from __future__ import annotations

import copy

import numpy as np
import pytest

from core import transforms as tf
from core.camera import CameraModel
from core.stereo.rectification import StereoRectification
from core.errors import RoboCalError
from core.marker.location import LocatorOptions, MarkerLocator, MarkerTracker, corner_planarity, square_pose
from core.stereo.rig import StereoRig

from tests.core import marker_scenes as scenes


@pytest.fixture(scope="module")
def locator():
    return MarkerLocator(scenes.trained(), StereoRectification.from_rig(scenes.lab().rig))


POSES = [(640, 512, 600, 0, 0), (800, 300, 450, 160, 40), (900, 700, 850, -60, 50)]


@pytest.fixture(scope="module")
def pairs():
    out = []
    for i, args in enumerate(POSES):
        T = scenes.pose_at(*args)
        out.append((T, *scenes.compose([T], [T], seed=i)))
    return out


@pytest.fixture(scope="module")
def located(locator, pairs):
    """The locator's result for each of `pairs`, located once for the tests that read them: locate
    is deterministic and keeps no state, and the tests only read the results."""
    return [locator.locate(left, right) for _, left, right in pairs]


def test_point_within_hundredths_of_a_millimetre(pairs, located):
    for (T, _, _), loc in zip(pairs, located):
        assert loc.ok, loc.reason
        err = np.linalg.norm(loc.point - T[:3, 3])
        assert err < 0.05
        assert np.all(loc.sigma > 0) and np.all(loc.sigma < 0.05)
        assert np.linalg.norm(loc.point_ssd - T[:3, 3]) < 0.2          # the chapter's SSD disparity
        assert np.linalg.norm(loc.point_general - loc.point) < 0.05     # eq. (22) agrees
        assert abs(loc.epipolar_error) < 0.1 and abs(loc.disparity_edges - loc.disparity_ssd) < 0.3
        assert loc.size_mm == pytest.approx(40.0, abs=0.1)
        np.testing.assert_allclose(loc.left_point, scenes.true_left(T), atol=0.05)
        c = loc.correspondence
        assert c.ok and c.warped and c.reliability < 0.3
        assert c.window[1] >= min(0.9 * np.ptp(loc.left.outline.corners_ideal[:, 0]), 151)   # the marker's size


def test_json_summary(located):
    d = located[0].to_dict()
    for key in ("x", "y", "z", "sigma", "covariance", "disparity", "disparity_ssd", "criteria_minimum",
                "reliability", "window", "sigma_px", "epipolar_error", "size_mm"):
        assert d[key] is not None, key
    assert len(d["left"]["image_point"]) == 2 and len(d["right"]["rectified"]) == 2
    import json
    json.dumps(d)


def test_chapter_method_option(pairs):
    loc = MarkerLocator(scenes.trained(), StereoRectification.from_rig(scenes.lab().rig),
                        LocatorOptions(method="ssd", general_check=False))
    T, left, right = pairs[0]
    r = loc.locate(left, right)
    assert r.ok and r.method == "ssd" and r.disparity == r.disparity_ssd
    assert np.linalg.norm(r.point - T[:3, 3]) < 0.2 and r.point_general is None


def test_no_marker_in_the_right_image(locator):
    T = scenes.pose_at(640, 512, 600, 10, 10)
    left, right = scenes.compose([T], [])
    loc = locator.locate(left, right)
    assert not loc.ok and loc.stage in ("ssd", "right") and loc.point is None
    assert loc.reason


@pytest.fixture(scope="module")
def ideal():
    """A lab with an exactly aligned, distortion-free pair (a twin marker then looks the same
    in both places, and swapped images rectify exactly), and its locator."""
    from core.virtual_lab.lab import VirtualLab
    from core.virtual_lab.rig import default_rig

    rig = default_rig(0, misalignment=False, distortion=(0, 0, 0, 0, 0))
    lab = VirtualLab.create(seed=0, rig=rig)
    return lab, MarkerLocator(scenes.trained(), StereoRectification.from_rig(rig))


def _pair(lab, left_poses, right_poses):
    left, right = lab._composers()
    for c, poses in ((left, left_poses), (right, right_poses)):
        for T in poses:
            c.draw_plate(lab.marker_texture, T)
    rng = np.random.default_rng(0)
    return left.finish(rng, 0.5, vignetting_strength=0.0), right.finish(rng, 0.5, vignetting_strength=0.0)


def test_second_marker_on_the_same_line_is_ambiguous(ideal):
    lab, locator = ideal
    T = scenes.pose_at(800, 512, 600, 10, 0)
    twin = T.copy()
    twin[:3, 3] += [-90.0, 0.0, 0.0]          # same depth and row, 90 mm to the left
    loc = locator.locate(*_pair(lab, [T], [T, twin]))
    assert not loc.ok and loc.stage == "ssd" and "ambiguous" in loc.reason and loc.point is None


def test_a_less_similar_second_marker_never_gives_a_wrong_point(locator):
    T = scenes.pose_at(800, 512, 600, 10, 10)
    twin = T.copy()
    twin[:3, 3] += [-90.0, 0.0, 0.0]
    left, right = scenes.compose([T], [T, twin])
    loc = locator.locate(left, right)
    assert (loc.ok and np.linalg.norm(loc.point - T[:3, 3]) < 0.05) or "ambiguous" in loc.reason
    if loc.ok:
        assert loc.correspondence.reliability > 0.01          # the twin shows as a second minimum


def test_swapped_images_give_no_positive_disparity(ideal):
    lab, locator = ideal
    T = scenes.pose_at(640, 512, 600, 10)
    left, right = _pair(lab, [T], [T])
    loc = locator.locate(right, left)
    assert not loc.ok and loc.stage == "ssd" and "≤ 0" in loc.reason


def test_swapped_images_of_a_real_pair_do_not_match(locator, pairs):
    _, left, right = pairs[0]
    loc = locator.locate(right, left)           # rows no longer correspond after rectification
    assert not loc.ok and loc.stage == "ssd" and loc.point is None


def test_marker_half_outside_the_left_image(locator):
    T = scenes.pose_at(20, 500, 600)
    left, right = scenes.compose([T], [T])
    loc = locator.locate(left, right)
    assert not loc.ok and loc.stage == "left" and "partly outside" in loc.reason


def test_wrong_marker_size_is_caught(pairs):
    small = copy.copy(scenes.trained())
    small.outer_size = 30.0
    loc = MarkerLocator(small, StereoRectification.from_rig(scenes.lab().rig)).locate(*pairs[0][1:])
    assert not loc.ok and loc.stage == "check" and "40.0 mm wide" in loc.reason
    unchecked = MarkerLocator(small, StereoRectification.from_rig(scenes.lab().rig),
                              LocatorOptions(max_size_error=None)).locate(*pairs[0][1:])
    assert unchecked.ok and np.linalg.norm(unchecked.point - pairs[0][0][:3, 3]) < 0.05


def test_stale_calibration_is_caught(pairs):
    rig = scenes.lab().rig
    tilted = StereoRig(rig.left, rig.right, rig.R @ tf.rot_axis(np.array([1.0, 0, 0]), np.deg2rad(0.08)), rig.T)
    loc = MarkerLocator(scenes.trained(), StereoRectification.from_rig(tilted)).locate(*pairs[0][1:])
    assert not loc.ok and loc.stage == "check" and "epipolar line" in loc.reason


def test_corner_disparities_off_one_plane(pairs, located):
    """The four corners' disparities lie on a plane (affine in u, v); one corner 0.2 px off
    leaves a quarter of it at every corner of a square (one residual degree of freedom)."""
    left = np.array([[100.0, 100.0], [300.0, 100.0], [300.0, 300.0], [100.0, 300.0]])
    right = left - (40.0 + 0.01 * left[:, :1] - 0.02 * left[:, 1:]) * [1.0, 0.0]
    assert corner_planarity(left, right) < 1e-9
    bent = right.copy()
    bent[0, 0] += 0.2
    assert corner_planarity(left, bent) == pytest.approx(0.05, abs=1e-9)
    for loc in located:
        assert loc.corner_planarity < 0.02      # px (nominal: ~0.002)
    strict = MarkerLocator(scenes.trained(), StereoRectification.from_rig(scenes.lab().rig),
                           LocatorOptions(max_corner_planarity=1e-6)).locate(*pairs[0][1:])
    assert not strict.ok and strict.stage == "check" and "off one plane" in strict.reason


def test_images_of_another_size(locator):
    with pytest.raises(RoboCalError, match="calibration is for 1280x1024"):
        locator.locate(np.zeros((480, 640), np.uint8), np.zeros((480, 640), np.uint8))


def test_tracking_from_a_predicted_pose_and_from_the_last_one(locator, pairs):
    tracker = MarkerTracker(locator)
    T, left, right = pairs[1]
    # the robot model's prediction is a few mm and a degree off
    guess = T @ tf.make_transform(tf.rot_axis(np.array([0.0, 1, 0]), np.deg2rad(1.0)), [1.0, -1.5, 2.0])
    loc = tracker.track(left, right, predicted_pose=guess)
    assert loc.ok and loc.mode == "tracking"
    assert loc.left.area.mode == "predicted" and loc.right.area.mode == "predicted"
    assert np.linalg.norm(loc.point - T[:3, 3]) < 0.05
    again = tracker.track(left, right)            # from the last location
    assert again.ok and again.mode == "tracking" and again.left.area.mode == "predicted"
    # the marker jumped elsewhere: tracking falls back to a full search
    T2, left2, right2 = pairs[2]
    jumped = tracker.track(left2, right2)
    assert jumped.ok and np.linalg.norm(jumped.point - T2[:3, 3]) < 0.05
    tracker.reset()
    assert tracker.last is None
    # a predicted point only (no orientation): first with no last location, then moving the last one
    T, left, right = pairs[0]
    loc = tracker.track(left, right, predicted_point=T[:3, 3] + [2.0, -1.0, 3.0])
    assert loc.ok and loc.mode == "tracking" and np.linalg.norm(loc.point - T[:3, 3]) < 0.05
    loc = tracker.track(left, right, predicted_point=T[:3, 3] + [1.0, 1.0, 0.0])
    assert loc.ok and loc.left.area.mode == "predicted"


def test_window_sweep_at_the_located_point(locator, pairs, located):
    _, left, right = pairs[0]
    loc = located[0]
    sweep = locator.window_sweep(left, right, loc)
    assert list(sweep.sizes) == list(range(5, 38, 2))
    assert np.all(np.isfinite(sweep.minima))
    assert np.all(np.abs(sweep.disparities - loc.disparity_ssd) < 1.0)


def test_square_pose_from_four_corners():
    K = np.array([[1500.0, 0, 640], [0, 1500, 512], [0, 0, 1]])
    T = scenes.pose_at(700, 400, 600, 30, 35)
    corners3 = tf.transform_points(T, scenes.trained().outline_mm())
    uv = corners3[:, :2] / corners3[:, 2:] * 1500 + [640, 512]
    n, centre = square_pose(uv, K, 40.0)
    assert abs(abs(n @ T[:3, 2]) - 1.0) < 1e-9
    np.testing.assert_allclose(centre, T[:3, 3], rtol=1e-5)


def test_rational_distortion_model():
    """Cameras with OpenCV's rational model (k4..k6): the marker is located with all 8 coefficients."""
    lab = copy.copy(scenes.lab())
    dist = [-0.28, 0.12, 0.0005, -0.0003, 0.01, 0.15, -0.05, 0.02]
    lab.rig = StereoRig(CameraModel(lab.rig.left.K, dist, *lab.rig.left.size),
                        CameraModel(lab.rig.right.K, dist, *lab.rig.right.size), lab.rig.R, lab.rig.T)
    T = scenes.pose_at(1000, 300, 600, 30, 30)
    left, right = lab.render_marker_at(T, np.random.default_rng(1))
    loc = MarkerLocator(scenes.trained(), StereoRectification.from_rig(lab.rig)).locate(left, right)
    assert loc.ok, loc.reason
    assert np.linalg.norm(loc.point - T[:3, 3]) < 0.05
    five = StereoRig(CameraModel(lab.rig.left.K, dist[:5], *lab.rig.left.size),
                     CameraModel(lab.rig.right.K, dist[:5], *lab.rig.right.size), lab.rig.R, lab.rig.T)
    cut = MarkerLocator(scenes.trained(), StereoRectification.from_rig(five)).locate(left, right)
    assert not cut.ok or np.linalg.norm(cut.point - T[:3, 3]) > 0.5      # k4..k6 matter here
