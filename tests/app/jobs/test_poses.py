"""app.jobs.poses.run_pose_selection: the Pose sequence step's work, with and without the virtual lab."""
from __future__ import annotations

import numpy as np
import pytest

from app.jobs.poses import run_pose_selection
from core.errors import Cancelled
from core.robot.file import read_robot
from core.robot.model import robot_path


@pytest.fixture(scope="module")
def robot():
    return read_robot(robot_path("educational_6r"))


@pytest.fixture(scope="module")
def lab(robot, built_lab):
    return built_lab(robot, 0, 0.5)


def test_without_a_lab_any_feasible_pose_of_the_robot(robot):
    r = run_pose_selection(robot, 12, candidates=200, index="O1", seed=3)
    assert r.robot is robot and r.index == "O1" and r.count == 12 and r.Q.shape == (12, 6)
    assert r.depth is None and len(r.candidates) == 200
    again = run_pose_selection(robot, 12, candidates=200, index="O1", seed=3)
    np.testing.assert_array_equal(again.Q, r.Q)              # same seed, same poses


def test_in_the_lab_the_cameras_see_every_pose(robot, lab):
    r = run_pose_selection(robot, 12, lab=lab, candidates=200, margin=10.0)
    assert r.robot is lab.nominal_robot and r.robot is not robot
    assert r.depth is not None and len(r.depth) == 12
    assert np.all((r.depth >= 400.0) & (r.depth <= 900.0))   # the lab's pose depth range, mm
    np.testing.assert_allclose(r.marker[:, 2], r.depth)       # marker z in the left camera frame is its depth
    margin = np.deg2rad(10.0)
    lo = np.array([j.min for j in robot.joints]) + margin
    hi = np.array([j.max for j in robot.joints]) - margin
    assert np.all((r.Q >= lo - 1e-9) & (r.Q <= hi + 1e-9))


def test_progress_and_cancel(robot):
    seen = []
    run_pose_selection(robot, 10, candidates=100, progress=lambda f, m: seen.append(f))
    assert seen and 0.0 <= min(seen) and max(seen) <= 1.0
    with pytest.raises(Cancelled):
        run_pose_selection(robot, 10, candidates=100, cancelled=lambda: True)
