"""Checks of a stereo calibration on reading: each implausible or inconsistent part is one
message naming the file and the field."""
from __future__ import annotations

import copy

import numpy as np
import pytest

from core.errors import RoboCalError
from core.stereo.checks import check_stereo
from core.stereo.completion import StereoParts, complete_stereo
from core.stereo.file import read_stereo_yaml, write_stereo_yaml


@pytest.fixture(scope="module")
def good():
    from core.virtual_lab.rig import default_rig
    rig = default_rig(0)
    sf, _ = complete_stereo(StereoParts(rig.left.size, rig.left.K, rig.left.dist, rig.right.K, rig.right.dist,
                                        rig.R, rig.T), "good")
    return sf


def changed(sf, key, change):
    bad = copy.deepcopy(sf)
    value = np.array(getattr(bad, key), dtype=float)
    setattr(bad, key, change(value))
    return bad


def _set(index, value):
    def change(m):
        m[index] = value
        return m
    return change


def _rotate_z(degrees):
    c, s = np.cos(np.radians(degrees)), np.sin(np.radians(degrees))
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1.0]])


CASES = [
    ("K1", _set((0, 0), -5.0), "focal lengths"),
    ("K2", lambda K: np.vstack([K[0], K[0], K[2]]), "not a camera matrix"),          # two equal rows
    ("K1", _set((2, 2), 0.0), "not a camera matrix"),
    ("K1", _set((0, 1), 3.0), "skew"),
    ("K1", _set((1, 1), 100.0), "aspect ratio"),
    ("K2", _set((0, 2), 5000.0), "principal point"),
    ("K1", _set((1, 2), -1.0), "principal point"),
    ("R", lambda R: R * 1.001, "not a rotation matrix"),
    ("R", lambda R: -R, "not a rotation matrix"),                                   # det −1
    ("T", lambda T: T * 0.0, "not zero"),
    ("T", _set(0, np.inf), "finite"),
    ("E", lambda E: E @ _rotate_z(1.0), "essential matrix disagrees"),
    ("F", lambda F: F @ _rotate_z(1.0), "fundamental matrix disagrees"),
    ("P2", _set((0, 3), 0.0), "baseline is zero"),
    ("P2", lambda P: P * np.array([1, 1, 1, 1.1]), "P2 disagrees with T"),
    ("P1", lambda P: P * 0.0, "projection matrix"),
    ("R1", lambda R: R * 0.0, "not a rectification rotation"),
    ("R2", lambda R: _rotate_z(2.0) @ R, "do not rectify"),
    ("Q", lambda Q: Q * 0.0, "singular"),
]


@pytest.mark.parametrize("key, change, says", CASES, ids=[f"{c[0]}-{c[2]}" for c in CASES])
def test_each_check_names_the_field(good, key, change, says):
    check_stereo(good, "s.yaml")                       # the unchanged file passes
    with pytest.raises(RoboCalError) as err:
        check_stereo(changed(good, key, change), "s.yaml")
    assert err.value.field == key and says in err.value.problem, err.value.message
    assert err.value.message.startswith(f"s.yaml: field '{key}': ") and "\n" not in err.value.message
    assert err.value.hint


def test_T_disagreeing_with_E_says_E(good):
    bad = changed(good, "T", lambda T: T + np.array([0.0, 20.0, 0.0]))
    with pytest.raises(RoboCalError, match="field 'E': the essential matrix disagrees with R and T"):
        check_stereo(bad, "s.yaml")


def test_computed_parts_are_not_compared(good):
    """What a file did not give is computed from R and T; only the given parts are compared."""
    bad = changed(good, "E", lambda E: E @ _rotate_z(5.0))
    check_stereo(bad, "s.yaml", given=frozenset({"F", "R1", "R2", "P1", "P2", "Q"}))


def test_read_stereo_yaml_checks(tmp_path, good):
    path = write_stereo_yaml(tmp_path / "stereo.yaml", changed(good, "K1", lambda K: np.vstack([K[0], K[0], K[2]])))
    with pytest.raises(RoboCalError, match=r"stereo.yaml: field 'K1': not a camera matrix"):
        read_stereo_yaml(path)
    path = write_stereo_yaml(tmp_path / "stereo.yaml", changed(good, "P1", lambda P: P * 0.0))
    with pytest.raises(RoboCalError, match=r"stereo.yaml: field 'P1': not a rectified projection matrix"):
        read_stereo_yaml(path)
