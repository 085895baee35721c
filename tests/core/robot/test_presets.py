"""Robot presets: each names its published source, stays within its datasheet reach, and survives the
robot file and a URDF export → robot-import round trip with the same forward kinematics.
(Positions at published poses: tests/core/robot/test_model.py, HAND_CHECKED.)"""
from __future__ import annotations

import json

import numpy as np
import pytest

from core.identification.exports import export_model
from core.robot.file import read_robot, write_robot
from core.robot.model import preset_names, robot_path
from core.robot.urdf_import import import_urdf

# maximum reach published in the datasheets (mm)
REACH_MM = {"ur3e": 500.0, "ur10e": 1300.0, "xarm6": 700.0, "kuka_kr6_r900": 901.5}


def configurations(model, n, seed=1):
    lo, hi = model.limits()
    return np.random.default_rng(seed).uniform(np.maximum(lo, -np.pi), np.minimum(hi, np.pi), (n, model.dof))


@pytest.mark.parametrize("name", sorted(REACH_MM))
def test_preset_names_its_source(name):
    data = json.loads(robot_path(name).read_text())
    assert len(data["source"]) > 40 and data["description"]
    assert all(j["name"] for j in data["joints"])


@pytest.mark.parametrize("name", sorted(REACH_MM))
def test_wrist_stays_within_the_published_reach(name):
    model = read_robot(robot_path(name))
    wrist = model.frames_many(configurations(model, 20000))[:, 5, :3, 3]
    furthest = float(np.hypot(wrist[:, 0], wrist[:, 1]).max())
    # makers measure reach to the wrist point or the flange centre: the wrist's furthest point from the
    # first axis lies at the published figure or a little beyond it, never far off
    assert 0.95 * REACH_MM[name] <= furthest <= 1.15 * REACH_MM[name], furthest


def test_kuka_reach_is_the_wrist_point_reach():
    model = read_robot(robot_path("kuka_kr6_r900"))
    wrist = model.frames_many(configurations(model, 20000))[:, 5, :3, 3]
    assert abs(np.hypot(wrist[:, 0], wrist[:, 1]).max() - 901.5) < 0.2


@pytest.mark.parametrize("name", preset_names())
def test_round_trips_through_the_robot_file_and_urdf(tmp_path, name):
    model = read_robot(robot_path(name))
    again = read_robot(write_robot(model, tmp_path / "robot.json"))
    export_model(model, "urdf", tmp_path / "robot.urdf")
    imported = import_urdf(tmp_path / "robot.urdf", base="world", tip="tool").model
    Q = configurations(model, 200, seed=4)
    expected = model.fk_many(Q)
    np.testing.assert_allclose(again.fk_many(Q), expected, atol=1e-9)
    np.testing.assert_allclose(imported.fk_many(Q)[:, :3, 3], expected[:, :3, 3], atol=1e-6)
    np.testing.assert_allclose(imported.fk_many(Q)[:, :3, :3], expected[:, :3, :3], atol=1e-9)
    assert [j.name for j in imported.joints] == [j.name for j in model.joints]
    np.testing.assert_allclose(imported.limits(), model.limits(), atol=1e-9)
