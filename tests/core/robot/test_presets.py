"""Robot presets: each names its published source, stays within its datasheet reach, and survives the
robot file and a URDF export → robot-import round trip with the same forward kinematics.
(Positions at published poses: tests/core/robot/test_model.py, HAND_CHECKED.)"""
from __future__ import annotations

import json
import math
import re
from pathlib import Path

import numpy as np
import pytest

from core.identification.exports import export_model
from core.robot.file import read_robot, write_robot
from core.robot.model import preset_names, robot_path
from core.robot.urdf_import import import_urdf

# maximum reach published in the datasheets (mm); FANUC's 717 mm is the LR Mate 200iD figure as public tables quote it
# from FANUC's product page, the myCobot 280's is Elephant Robotics' working radius (mycobot_docs, product parameters)
REACH_MM = {"ur3e": 500.0, "ur10e": 1300.0, "xarm6": 700.0, "kuka_kr6_r900": 901.5,
            "fanuc_lrmate200id": 717.0, "mycobot_280": 280.0}
# presets with a published source (no reach figure was found for the Moveo or Thor)
SOURCED = sorted(set(REACH_MM) | {"bcn3d_moveo", "thor"})

# The source URDFs copied under tests/data/robots (licence and origin in each file): preset -> (file, base link, tip
# link, position and rotation tolerance). The myCobot and Moveo files write π/2 and π as 1.5708 and 3.1416, which the
# presets read as exact: each rounded angle (≤ 7.4e-6 rad) turns the rest of the arm, so the tip moves by at most
# their sum times the arm's length (myCobot: 5 × 3.7e-6 rad × 0.52 m ≈ 0.01 mm; Moveo: 4 × 3.7e-6 + 4 × 7.4e-6 rad
# × 0.7 m ≈ 0.03 mm; measured 0.0016 and 0.005 mm).
DATA = Path(__file__).resolve().parents[2] / "data" / "robots"
URDF_SOURCES = {
    "fanuc_lrmate200id": ("fanuc_lrmate200id.urdf", "base_link", "tool0", 1e-6, 1e-9),
    "mycobot_280": ("mycobot_280_m5.urdf", "g_base", "joint6_flange", 0.01, 2e-5),
    "bcn3d_moveo": ("bcn3d_moveo.urdf", "base_link", "Link_5", 0.03, 5e-5),
}


def exact_right_angles(text: str) -> str:
    """The URDF text with rpy values written 1.5708 / 3.1416 replaced by π/2 / π."""
    exact = {"1.5708": math.pi / 2, "3.1416": math.pi}

    def fix(match):
        values = [repr(math.copysign(exact[v.lstrip("-")], -1.0 if v.startswith("-") else 1.0))
                  if v.lstrip("-") in exact else v for v in match.group(1).split()]
        return 'rpy="' + " ".join(values) + '"'
    return re.sub(r'rpy\s*=\s*"([^"]*)"', fix, text)


def configurations(model, n, seed=1):
    lo, hi = model.limits()
    return np.random.default_rng(seed).uniform(np.maximum(lo, -np.pi), np.minimum(hi, np.pi), (n, model.dof))


@pytest.mark.parametrize("name", SOURCED)
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


@pytest.mark.parametrize("name", sorted(URDF_SOURCES))
def test_forward_kinematics_equal_the_source_urdf(name):
    """Independently of RoboCal: yourdfpy's forward kinematics of the source URDF at zero and at 200 configurations."""
    yourdfpy = pytest.importorskip("yourdfpy")
    filename, base, tip, tol_mm, tol_rot = URDF_SOURCES[name]
    model = read_robot(robot_path(name))
    urdf = yourdfpy.URDF.load(str(DATA / filename), load_meshes=False, build_scene_graph=True)
    assert urdf.actuated_joint_names == [j.name for j in model.joints]
    Q = np.vstack([np.zeros(model.dof), configurations(model, 200, seed=5)])
    for q, T in zip(Q, model.fk_many(Q)):
        urdf.update_cfg(q)
        ref = urdf.get_transform(tip, base)
        assert np.abs(T[:3, 3] - 1000 * ref[:3, 3]).max() < tol_mm
        assert np.abs(T[:3, :3] - ref[:3, :3]).max() < tol_rot


@pytest.mark.parametrize("name", sorted(URDF_SOURCES))
def test_preset_is_the_robot_import_of_its_source(tmp_path, name):
    """The preset's DH, base and tool are robot-import's conversion of the source URDF (π/2 and π exact)."""
    filename, base, tip, _, _ = URDF_SOURCES[name]
    path = tmp_path / filename
    path.write_text(exact_right_angles((DATA / filename).read_text()))
    imported = import_urdf(path, base=base, tip=tip).model
    model = read_robot(robot_path(name))
    for key, expected in model.dh_arrays().items():
        np.testing.assert_allclose(imported.dh_arrays()[key], expected, atol=1e-8, err_msg=key)
    np.testing.assert_allclose(imported.base, model.base, atol=1e-8)
    np.testing.assert_allclose(imported.tool, model.tool, atol=1e-8)
