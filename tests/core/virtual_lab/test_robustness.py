"""The robustness sweep: detection rate and 3D error per condition value, on a small seeded set."""
from __future__ import annotations

import numpy as np
import pytest

from core.errors import Cancelled
from core.marker.location import LocatorOptions, MarkerLocator
from core.stereo.rectification import StereoRectification
from core.virtual_lab.conditions import ImagingConditions, marker_pose
from core.virtual_lab.robustness import RobustnessRow, robustness_sweep

from tests.core import marker_scenes as scenes


def _locator(options: LocatorOptions | None = None) -> MarkerLocator:
    return MarkerLocator(scenes.trained(), StereoRectification.from_rig(scenes.lab().rig), options)


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


@pytest.mark.parametrize("index", [22, 35])
def test_an_outline_found_differently_in_the_two_images_is_rejected(index):
    """Two views the sweep found (30 % covered over a corner, seed 5): the outline's first corner
    lies on different rectified rows in the two images. The reference points alone pass every
    other check and would give a point 2.5 mm off; the corners' row check rejects it."""
    lab = scenes.lab()
    conditions = ImagingConditions(occlusion=0.3, side="corner")
    T = marker_pose(lab, np.random.default_rng([5, 41, index]), conditions)
    left, right = lab.render_marker_at(T, np.random.default_rng([5, 42, index]), conditions=conditions)
    loc = _locator().locate(left, right)
    assert not loc.ok and loc.stage == "check" and "corner 1 of the outer square" in loc.reason
    loose = _locator(LocatorOptions(epipolar_tolerance=6.0)).locate(left, right)
    assert loose.ok and np.linalg.norm(loose.point - T[:3, 3]) > 2.0
