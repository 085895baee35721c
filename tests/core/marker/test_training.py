"""Marker training: outline, reference point, SIFT features, refusal of a textureless marker, files."""
from __future__ import annotations

import numpy as np
import pytest

from core.errors import RoboCalError
from core.virtual_lab.marker_comparison import plain_pattern
from core.marker.description import MarkerDescription
from core.marker.training import TrainedMarker, find_outline, train_from_description, train_marker

from tests.core import marker_scenes as scenes


def test_training_image_outline_and_reference_to_hundredths_of_a_pixel():
    lab = scenes.lab()
    image = lab.render_training_image()
    geometry = lab.training_geometry()
    truth = np.array(geometry["outer_corners_px"])
    auto = train_marker(image)                     # outline found automatically
    np.testing.assert_allclose(auto.outline, truth, atol=0.02)
    np.testing.assert_allclose(auto.reference_px, geometry["reference_px"], atol=0.02)
    assert auto.outer_size == 40.0
    assert auto.n_image_features >= 100
    assert auto.n_features > 3 * auto.n_image_features        # simulated tilted views add features
    assert np.all((auto.keypoint_view >= 0) & (auto.keypoint_view <= 9))
    # the clean band inside (4.8 mm of 40) and the white border outside (12 mm of 40)
    np.testing.assert_allclose(auto.inner_band.min(), 0.12, atol=0.01)
    assert np.all(auto.outer_border > 0.25)
    assert auto.bright_level - auto.dark_level > 150


def test_find_outline_is_ordered_clockwise_from_top_left():
    image = scenes.lab().render_training_image()
    quad = find_outline(image)
    np.testing.assert_allclose(quad, scenes.lab().training_geometry()["outer_corners_px"], atol=1.0)


def test_train_from_the_marker_description_png():
    desc = MarkerDescription.default()
    m = train_from_description(desc)
    np.testing.assert_allclose(m.outline, desc.outer_corners_px, atol=0.01)
    np.testing.assert_allclose(m.reference_px, desc.reference_px, atol=0.01)
    assert m.outer_size == desc.outer_size


def test_too_few_features_says_how_many_and_why():
    with pytest.raises(RoboCalError) as err:
        train_marker(plain_pattern())
    text = err.value.message
    assert "only" in text and "SIFT features" in text and "texture" in text and "asymmetric" in text


def test_no_square_in_the_image():
    rng = np.random.default_rng(0)
    noise = rng.integers(100, 160, (300, 300)).astype(np.uint8)
    with pytest.raises(RoboCalError, match="no dark square"):
        train_marker(noise)
    with pytest.raises(RoboCalError, match="outline corners"):
        train_marker(scenes.lab().render_training_image(), [[0, 0], [10, 0], [0, 10], [10, 10.0]][:3] + [[5, 5]])


def test_save_and_load_round_trip(tmp_path):
    m = scenes.trained()
    path = m.save(tmp_path / "marker.npz")
    back = TrainedMarker.load(path)
    np.testing.assert_array_equal(back.image, m.image)
    np.testing.assert_allclose(back.outline, m.outline)
    np.testing.assert_allclose(back.descriptors, m.descriptors)
    np.testing.assert_array_equal(back.keypoint_view, m.keypoint_view)
    assert back.outer_size == m.outer_size and back.name == m.name
    assert len(back.keypoints()) == m.n_image_features


def test_load_refuses_other_files(tmp_path):
    bad = tmp_path / "x.npz"
    np.savez(bad, format=np.array("robocal.other/1"))
    with pytest.raises(RoboCalError, match="not a trained marker"):
        TrainedMarker.load(bad)
    newer = tmp_path / "y.npz"
    np.savez(newer, format=np.array("robocal.trained_marker/2"))
    with pytest.raises(RoboCalError, match="unknown format version 2"):
        TrainedMarker.load(newer)
    text = tmp_path / "z.npz"
    text.write_text("hello")
    with pytest.raises(RoboCalError, match="not a trained-marker file"):
        TrainedMarker.load(text)
