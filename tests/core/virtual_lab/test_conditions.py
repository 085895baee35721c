"""Imaging conditions of the virtual lab: the light gain, the occluder on the marker, the tilt."""
from __future__ import annotations

import cv2
import numpy as np
import pytest

from core import transforms as tf
from core.errors import RoboCalError
from core.virtual_lab.conditions import ImagingConditions, marker_pose, occluder_rect, pose_tilt

from tests.core import marker_scenes as scenes

FRONTAL = scenes.pose_at(640.0, 480.0, 500.0)        # facing the left camera, ~120 px wide square


def _pair(conditions, *, noise=0.0, seed=3):
    return scenes.lab().render_marker_at(FRONTAL, np.random.default_rng(seed), noise=noise, conditions=conditions)


def test_light_scales_the_scene_and_keeps_the_sensor_noise():
    bright, _ = _pair(ImagingConditions(light=1.0))
    dim, _ = _pair(ImagingConditions(light=0.3))
    # a gain on the scene: the mean drops with the light (rounding to whole grey levels: ±0.5)
    assert dim.mean() == pytest.approx(0.3 * bright.mean(), abs=0.5)
    assert bright.mean() > 60
    noise, predicted = {}, {}
    for light in (1.0, 0.1):
        clean, _ = _pair(ImagingConditions(light=light))
        noisy, _ = _pair(ImagingConditions(light=light), noise=3.0)
        noise[light] = float(np.std(noisy.astype(float) - clean))
        # read noise 3 grey levels plus shot noise 3·√(s/255), plus the rounding of both images
        predicted[light] = float(np.sqrt(np.mean(9.0 * (1.0 + clean / 255.0)) + 2 / 12))
    assert noise[1.0] == pytest.approx(predicted[1.0], rel=0.03)
    # at a tenth of the light the noise hardly falls (the read noise stays; the darkest pixels
    # clip at 0), while the signal falls tenfold: the SNR drops about tenfold
    assert 0.75 * noise[1.0] < noise[0.1] < noise[1.0]


def test_light_applies_to_robot_pairs():
    lab = scenes.lab()
    q = lab.random_visible_poses(1, np.random.default_rng(1))[0]
    a, _ = lab.render_marker_pair(q, np.random.default_rng(2), noise=0.0)
    b, _ = lab.render_marker_pair(q, np.random.default_rng(2), noise=0.0, conditions=ImagingConditions(light=0.5))
    assert b.mean() == pytest.approx(0.5 * a.mean(), abs=0.5)


def _square_mask(lab, T) -> np.ndarray:
    """Left-image pixels whose centres lie inside the marker's outer square (edges sampled so
    that the lens distortion's curvature is followed)."""
    t = np.linspace(0.0, 1.0, 41)[:-1]
    c = lab.marker.outer_corners()
    pts = np.concatenate([c[k] + t[:, None] * (c[(k + 1) % 4] - c[k]) for k in range(4)])
    uv = lab.rig.left.project(tf.transform_points(T, pts))
    mask = np.zeros((lab.rig.left.height, lab.rig.left.width), np.uint8)
    cv2.fillPoly(mask, [np.round((uv + 0.5) * 16).astype(np.int32)], 1, cv2.LINE_8, 4)
    return mask.astype(bool)


@pytest.mark.parametrize("side, fraction", [("left", 0.3), ("top", 0.1), ("corner", 0.2), ("corner", 0.5)])
def test_the_occluder_covers_the_requested_fraction_of_the_marker(side, fraction):
    lab = scenes.lab()
    clean, _ = _pair(ImagingConditions())
    covered, _ = _pair(ImagingConditions(occlusion=fraction, side=side))
    inside = _square_mask(lab, FRONTAL)
    changed = np.abs(covered.astype(float) - clean) > 6.0
    measured = float(changed[inside].mean())
    # rasterisation and the 0.7 px optical blur blur the occluder's edge by about 1.5 px: over its
    # length across a ~120 px square that is at most 1.5 · 120 / 120² ≈ 0.013 of the area
    side_px = np.sqrt(inside.sum())
    assert measured == pytest.approx(fraction, abs=1.5 / side_px + 0.002)
    assert not changed[~inside & (np.abs(covered.astype(float) - 128) > 200)].any()   # nothing else


def test_occluder_rect_area():
    for side in ("left", "right", "top", "bottom", "corner"):
        x0, x1, y0, y1 = occluder_rect(40.0, (64.0, 64.0), 0.25, side)
        inside = (min(x1, 20) - max(x0, -20)) * (min(y1, 20) - max(y0, -20))
        assert inside == pytest.approx(0.25 * 1600.0)


def test_tilted_poses_have_the_requested_tilt_and_stay_in_view():
    lab = scenes.lab()
    for tilt in (0.0, 40.0, 70.0):
        T = marker_pose(lab, np.random.default_rng(5), ImagingConditions(tilt=tilt))
        assert pose_tilt(lab, T) == pytest.approx(tilt, abs=1e-6)
        corners = tf.transform_points(T, lab.marker.plate_corners())
        assert lab.rig.left.in_image(lab.rig.left.project(corners)).all()
        assert lab.rig.right.in_image(lab.rig.right.project(lab.rig.to_right(corners))).all()
        assert 400.0 <= T[2, 3] <= 900.0
    nominal = [pose_tilt(lab, marker_pose(lab, np.random.default_rng(s))) for s in range(20)]
    assert max(nominal) <= 30.0 + 1e-9 and min(nominal) < 15.0


@pytest.mark.parametrize("kwargs, field", [({"light": 0.0}, "light"), ({"light": 2.0}, "light"),
                                           ({"occlusion": 0.95}, "occlusion"), ({"side": "middle"}, "side"),
                                           ({"tilt": 90.0}, "tilt")])
def test_bad_conditions_name_the_field(kwargs, field):
    with pytest.raises(RoboCalError) as exc:
        ImagingConditions(**kwargs)
    assert exc.value.field == field
