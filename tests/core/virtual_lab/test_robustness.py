"""The robustness sweep: detection rate and 3D error per condition value, on a small seeded set."""
from __future__ import annotations

import numpy as np
import pytest

from core.errors import Cancelled
from core.marker.detection import DetectionOptions
from core.marker.edges import EdgeOptions
from core.marker.location import LocatorOptions, MarkerLocator
from core.stereo.rectification import StereoRectification
from core.virtual_lab.conditions import ImagingConditions, marker_pose
from core.virtual_lab.robustness import RobustnessRow, robustness_sweep

from tests.core import marker_scenes as scenes


def _locator(options: LocatorOptions | None = None) -> MarkerLocator:
    return MarkerLocator(scenes.trained(), StereoRectification.from_rig(scenes.lab().rig), options)


def _through_covered(**kw) -> LocatorOptions:
    """Edge model over the whole side, covered stretch included (no gap in the Canny edge excluded)."""
    return LocatorOptions(detection=DetectionOptions(edge=EdgeOptions(max_edge_gap=np.inf)), **kw)


def _views(occlusion: float, seed: int, indices):
    lab = scenes.lab()
    conditions = ImagingConditions(occlusion=occlusion, side="corner")
    for i in indices:
        T = marker_pose(lab, np.random.default_rng([seed, 41, i]), conditions)
        yield T, *lab.render_marker_at(T, np.random.default_rng([seed, 42, i]), conditions=conditions)


def test_sweep_nominal_is_found_heavy_occlusion_is_not_and_nothing_wrong_is_accepted():
    seen = []
    table = robustness_sweep(scenes.lab(), _locator(), light=(1.0, 0.05), occlusion=(0.6,), tilt=(40.0,), pairs=4,
                             seed=1, progress=lambda f, m: seen.append(f))
    assert [(r.axis, r.value) for r in table.rows] == [("light", 1.0), ("light", 0.05), ("occlusion", 0.6),
                                                      ("tilt", 40.0)]
    by = {(r.axis, r.value): r for r in table.rows}
    nominal = by[("light", 1.0)]
    assert nominal.rendered == 4 and nominal.detection_rate == 1.0
    assert nominal.median_error < 0.05 and nominal.p95_error < 0.1           # mm (measured ~0.005 / 0.015)
    assert by[("tilt", 40.0)].detection_rate == 1.0
    for key in (("light", 0.05), ("occlusion", 0.6)):                        # too dark / too much covered
        r = by[key]
        assert r.detection_rate < 0.5 and sum(r.reasons.values()) == r.rendered - r.located
    assert table.wrong == 0
    assert seen == sorted(seen) and seen[-1] == 1.0
    d = table.to_dict()
    assert d["wrongly_accepted"] == 0 and d["rows"][0]["detection_rate"] == 1.0 and d["occlusion_side"] == "corner"
    text = table.text()
    assert "light 0.05x" in text and "occlusion 60 %" in text and "tilt 40°" in text


def test_row_statistics_and_wrong_count():
    row = RobustnessRow("tilt", 70.0, rendered=5, errors=[0.01, 0.02, 0.03, 2.5])
    assert row.located == 4 and row.detection_rate == pytest.approx(0.8)
    assert row.median_error == pytest.approx(0.025) and row.wrong == 1
    assert row.p95_error == pytest.approx(np.percentile([0.01, 0.02, 0.03, 2.5], 95))
    empty = RobustnessRow("light", 0.1, rendered=3)
    assert empty.detection_rate == 0.0 and np.isnan(empty.median_error) and empty.to_dict()["median_error_mm"] is None


def test_sweep_can_be_cancelled():
    with pytest.raises(Cancelled):
        robustness_sweep(scenes.lab(), _locator(), light=(1.0,), occlusion=(), tilt=(), pairs=3,
                         cancelled=lambda: True)


@pytest.mark.parametrize("seed, index", [(1, 23), (3, 51)])
def test_an_outline_found_differently_in_the_two_images_is_rejected(seed, index):
    """Two views the sweep found (30 % covered over a corner). Fitted through the covered
    stretch, the outline's first corner lies on different rectified rows in the two images: the
    reference points alone pass every other check and would give a point more than 1 mm off
    (measured 1.88 / 1.13 mm); the corners' row check rejects it. Leaving the covered stretch
    out locates it (measured 0.011 / 0.029 mm)."""
    T, left, right = next(_views(0.3, seed, [index]))
    loc = _locator(_through_covered()).locate(left, right)
    assert not loc.ok and loc.stage == "check" and "corner 1 of the outer square" in loc.reason
    loose = _locator(_through_covered(epipolar_tolerance=6.0, max_corner_planarity=None)).locate(left, right)
    assert loose.ok and np.linalg.norm(loose.point - T[:3, 3]) > 1.0
    fitted = _locator().locate(left, right)
    assert fitted.ok and np.linalg.norm(fitted.point - T[:3, 3]) < 0.05


def test_a_marker_covered_over_a_corner_is_located_as_precisely_as_a_clear_one():
    """10 % of the outer square covered over a corner, 8 views (seed 3): the edge model leaves
    out the stretch of each side with no Canny edge, so the occluder does not bend the lines.
    Measured: median 0.007 mm, largest 0.024 mm (fitted through the covered stretch: median
    0.1 mm, largest 0.6 mm); clear views 0.002–0.021 mm."""
    locator, through = _locator(), _locator(_through_covered())
    errors, old = [], []
    for T, left, right in _views(0.1, 3, range(8)):
        loc = locator.locate(left, right)
        assert loc.ok, loc.reason
        errors.append(np.linalg.norm(loc.point - T[:3, 3]))
        b = through.locate(left, right)
        old.append(np.linalg.norm(b.point - T[:3, 3]) if b.ok else np.inf)
    assert np.median(errors) < 0.015 and max(errors) < 0.05          # mm
    assert np.median(old) > 0.04                                       # the fix is what makes the difference


def test_a_clear_marker_is_located_exactly_as_before():
    """No corner covered: the Canny edge has no gap, the edge model uses the whole band as
    before and the located point is the same (errors 0.0003–0.021 mm, 8 views, seed 3)."""
    locator, through = _locator(), _locator(_through_covered())
    for T, left, right in _views(0.0, 3, range(8)):
        a, b = locator.locate(left, right), through.locate(left, right)
        assert a.ok and b.ok
        np.testing.assert_allclose(a.point, b.point, rtol=0, atol=1e-9)
        assert np.linalg.norm(a.point - T[:3, 3]) < 0.03 and a.corner_planarity < 0.02    # mm, px
