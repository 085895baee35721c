"""The Marker step's verification as it runs: each pose's result handed on as it comes, and a
Cancel that keeps the poses measured (the same numbers as those poses of a full run)."""
from __future__ import annotations

import numpy as np
import pytest

from app.jobs.marker import capture_training_image, run_verification, train_job
from app.pages.measurement_inputs import preview_source
from core.errors import Cancelled
from core.marker.location import LocatorOptions, MarkerLocator

POSES = 5


@pytest.fixture(scope="module")
def lab(built_lab):
    return built_lab(None, 0, 0.5)                     # the educational 6R arm


@pytest.fixture(scope="module")
def locator(lab):
    captured = capture_training_image(lab)
    trained = train_job(captured.image, None, captured.outer_size, captured.source).trained
    return MarkerLocator(trained, preview_source(lab).rect, LocatorOptions())


def test_each_pose_is_handed_on_and_cancel_keeps_those_measured(lab, locator):
    full = run_verification(lab, locator, POSES, 0, 1, "preview")
    seen = []
    kept = run_verification(lab, locator, POSES, 0, 1, "preview", shown=seen.append,
                            cancelled=lambda: len(seen) >= 2)             # Cancel after the second pose
    assert [v.n for v in seen] == [1, 2] and all(v.poses_planned == POSES and v.cancelled_after is None for v in seen)
    assert kept.n == 2 and kept.cancelled_after == 2 and kept.poses_planned == POSES
    assert np.array_equal(kept.located, full.located[:2])
    assert np.allclose(kept.errors, full.errors[:2], equal_nan=True)
    assert np.allclose(kept.depth, full.depth[:2])
    assert kept.to_dict()["poses"] == 2
    # the snapshots are copies: what was handed on does not change under the reader
    assert seen[0].n == 1 and np.allclose(seen[0].errors, full.errors[:1], equal_nan=True)
    with pytest.raises(Cancelled):                    # nothing measured yet: nothing to keep
        run_verification(lab, locator, POSES, 0, 1, "preview", cancelled=lambda: True)
