"""The candidate-pattern comparison (chapter Fig. 11): the asymmetric default marker wins."""
from __future__ import annotations

import numpy as np

from core.virtual_lab.marker_comparison import (candidate_patterns, checker_pattern, compare_markers, random_marker_pose,
                                    rings_pattern, text_pattern, view_tilt)

from tests.core import marker_scenes as scenes


def test_patterns_share_the_outer_square():
    pats = candidate_patterns()
    assert [p.key for p in pats] == ["default", "plain", "checker", "rings", "text"]
    for img in (checker_pattern(), rings_pattern(), text_pattern()):
        assert img.shape == (800, 800)
        assert img[150:210, 150:650].max() == 0 and img[590:650, 150:650].max() == 0     # the clean band
        assert img[:150].min() == 255                                                    # the white border
        assert img[210:590, 210:590].max() == 255                                        # something inside
    for p in pats:
        np.testing.assert_allclose(p.description.outer_corners_px, [[149.5, 149.5], [649.5, 149.5],
                                                                    [649.5, 649.5], [149.5, 649.5]])
        assert p.description.outer_size == 40.0


def test_default_wins_and_a_plain_square_cannot_be_trained():
    pats = [p for p in candidate_patterns() if p.key in ("default", "plain", "rings")]
    result = compare_markers(pats, views=3, lab=scenes.lab())
    by = {p.key: p for p in result.patterns}
    assert result.recommended == "default"
    assert by["default"].trained and by["default"].detection_rate == 1.0 and by["default"].wrong == 0
    assert by["default"].mean_inliers >= 10 and by["default"].median_error < 0.05
    assert not by["plain"].trained and "SIFT features" in by["plain"].training_reason
    assert by["plain"].detection_rate == 0.0 and by["plain"].reasons == {"not trained": 3}
    assert by["rings"].mean_inliers < by["default"].mean_inliers
    table = result.table()
    assert "Plain black square" in table and "Asymmetric" in table
    assert by["default"].summary()["views"] == 3


def test_random_marker_poses_cover_tilt_and_stay_in_view():
    lab = scenes.lab()
    rng = np.random.default_rng(0)
    poses = [random_marker_pose(lab, rng) for _ in range(30)]
    tilts = [view_tilt(T) for T in poses]
    assert max(tilts) <= 60.0 + 1e-6 and max(tilts) > 35.0
    depth = [T[2, 3] for T in poses]
    assert min(depth) >= 400.0 and max(depth) <= 900.0
    for T in poses:
        corners = T[:3, :3] @ lab.marker.plate_corners().T + T[:3, 3:4]
        assert lab.rig.left.in_image(lab.rig.left.project(corners.T)).all()
