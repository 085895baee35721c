"""Fuzzing the fixture files: fixture descriptions read by `locate-fixture` (exit 1 or 2, one
stderr line naming the file, no output written; a valid mutation ends in the empty pairs folder's
refusal) and fixture pose files read back (a RoboCalError, never another exception)."""
from __future__ import annotations

import json

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from core.errors import RoboCalError
from core.fixtures.file import read_fixture_pose, write_fixture_pose
from core.fixtures.frame import fit_fixture_frame
from tests.fuzz.test_fuzz_commands import JUNK, assert_one_clear_line, mutate, robot_paths, run
from tests.fuzz.test_fuzz_files import calibrated

FUZZ = settings(derandomize=True, max_examples=80, deadline=None, database=None,
                suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
DESCRIPTION = {"format": "robocal.fixture-description/1", "name": "jig",
               "points": [{"name": "A", "position_mm": [0, 0, 0]}, {"name": "B", "position_mm": [220, 0, 0]},
                          {"name": "C", "position_mm": [220, 160, 40]}, {"name": "D", "position_mm": [0, 160, 0]}]}
NOMINAL = np.array([p["position_mm"] for p in DESCRIPTION["points"]], dtype=float)


@FUZZ
@given(where=st.sampled_from(list(robot_paths(DESCRIPTION))), value=JUNK)
def test_malformed_fixture_descriptions(files, tmp_path_factory, where, value):
    work = tmp_path_factory.mktemp("fixture")
    (work / "calibrated.json").write_text(json.dumps(calibrated(files)))
    description = work / "fixture.json"
    description.write_text(json.dumps(mutate(json.loads(json.dumps(DESCRIPTION)), where, value), allow_nan=True))
    (work / "pairs").mkdir()
    code, err = run(["locate-fixture", "--stereo", str(work / "stereo.yaml"), "--marker", str(work / "m.png"),
                     "--calibrated", str(work / "calibrated.json"), "--fixture", str(description),
                     str(work / "pairs"), "--out", str(work / "pose.json")], work)
    assert_one_clear_line(code, err, [str(description), str(work / "pairs")])
    assert not (work / "pose.json").exists()


POSE = None


def _pose(tmp_path_factory) -> dict:
    global POSE
    if POSE is None:
        path = tmp_path_factory.mktemp("pose") / "pose.json"
        write_fixture_pose(path, fit_fixture_frame(NOMINAL + [400.0, 0.0, 0.0], NOMINAL, np.array([np.eye(3)] * 4)))
        POSE = json.loads(path.read_text())
    return json.loads(json.dumps(POSE))


@FUZZ
@given(data=st.data(), value=JUNK)
def test_malformed_fixture_pose_files(tmp_path_factory, data, value):
    pose = _pose(tmp_path_factory)
    where = data.draw(st.sampled_from(list(robot_paths(pose))))
    path = tmp_path_factory.mktemp("bad") / "pose.json"
    path.write_text(json.dumps(mutate(pose, where, value), allow_nan=True))
    try:
        read_fixture_pose(path)
    except RoboCalError as exc:
        assert str(path) in exc.message
