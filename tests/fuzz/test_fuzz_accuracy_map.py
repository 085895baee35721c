"""Fuzzing the accuracy map file (accuracy_map.json): any field replaced by junk is read back as
a map or refused with a RoboCalError naming the file — never another exception."""
from __future__ import annotations

import json

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from core.compensation.accuracy_map import AccuracyMap
from core.compensation.accuracy_map_file import read_accuracy_map, write_accuracy_map
from core.errors import RoboCalError
from tests.fuzz.test_fuzz_commands import JUNK, mutate, robot_paths

FUZZ = settings(derandomize=True, max_examples=120, deadline=None, database=None,
                suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])


def _map_dict(tmp_path_factory) -> dict:
    rng = np.random.default_rng(0)
    targets = rng.uniform(-200, 200, (3, 3)) + [0, 0, 700]
    after = targets + rng.normal(0, 0.05, (3, 3))
    before = targets + rng.normal(0, 4.0, (3, 3))
    before[2] = np.nan                                        # one target not measured
    q = rng.uniform(-1, 1, (3, 6))
    amap = AccuracyMap(targets, before, after, q, q + 0.01, np.eye(4), "virtual lab", ["", "", "marker not found"],
                       "calibrated.json")
    path = write_accuracy_map(tmp_path_factory.mktemp("map") / "accuracy_map.json", amap)
    return json.loads(path.read_text())


MAP = None


@FUZZ
@given(data=st.data(), value=JUNK)
def test_malformed_accuracy_map_files(tmp_path_factory, data, value):
    global MAP
    if MAP is None:
        MAP = _map_dict(tmp_path_factory)
    good = json.loads(json.dumps(MAP))
    where = data.draw(st.sampled_from(list(robot_paths(good))))
    path = tmp_path_factory.mktemp("bad") / "accuracy_map.json"
    path.write_text(json.dumps(mutate(good, where, value), allow_nan=True))
    try:
        amap = read_accuracy_map(path)
    except RoboCalError as exc:
        assert str(path) in exc.message
    else:
        assert amap.n == 3 and amap.targets.shape == (3, 3) and np.all(np.isfinite(amap.targets))
