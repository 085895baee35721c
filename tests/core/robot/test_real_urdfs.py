"""URDFs of industrial arms as their makers' ROS packages publish them (tests/data/real/README.md
names each source, commit and licence): RoboCal's DH model of each chain against yourdfpy, an
independent URDF reader, at random joint values inside the URDF's limits."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from app.cli import main
from core.errors import RoboCalError
from core.robot.file import read_robot
from core.robot.urdf_import import import_urdf

yourdfpy = pytest.importorskip("yourdfpy")

DATA = Path(__file__).resolve().parents[2] / "data"
REAL = DATA / "real"

# file, tip link (None: the one moving end link), base link RoboCal finds, number of joints
ARMS = [("ur5_robot.urdf", "ee_link", "world", 6),
        ("abb_irb2400.urdf", None, "base_link", 6),
        ("kuka_kr16_2.urdf", None, "base_link", 6),
        ("fanuc_lrmate200ic.urdf", None, "base_link", 6),
        ("franka_panda.urdf", None, "world", 7),
        ("franka_panda_hand.urdf", "panda_hand", "panda_link0", 7),
        ("kinova_gen3_lite.urdf", "tool_frame", "world", 6)]
ALL = [(REAL / f, tip, base, dof) for f, tip, base, dof in ARMS] + [
    (DATA / "robots" / "fanuc_lrmate200id.urdf", None, "base_link", 6)]


@pytest.mark.parametrize("path, tip, base, dof", ALL, ids=[a[0].stem for a in ALL])
def test_forward_kinematics_equal_yourdfpy(path, tip, base, dof):
    imported = import_urdf(path, tip=tip)
    model = imported.model
    assert model.dof == dof and imported.base_link == base
    urdf = yourdfpy.URDF.load(str(path), load_meshes=False, build_scene_graph=True, build_collision_scene_graph=False)
    names = [j.name for j in model.joints]
    lower = np.array([urdf.joint_map[n].limit.lower for n in names])
    upper = np.array([urdf.joint_map[n].limit.upper for n in names])
    np.testing.assert_allclose(model.limits()[0], lower, atol=1e-12)      # rad, as the file writes them
    np.testing.assert_allclose(model.limits()[1], upper, atol=1e-12)
    rng = np.random.default_rng(7)
    worst = 0.0
    for q in rng.uniform(np.maximum(lower, -2 * np.pi), np.minimum(upper, 2 * np.pi), (100, dof)):
        cfg = dict(zip(names, q))
        cfg.update({n: 0.0 for n in urdf.actuated_joint_names if n not in cfg})     # fingers, off the chain
        urdf.update_cfg(cfg)
        ref = urdf.get_transform(imported.tip_link, imported.base_link)
        T = model.fk(q)
        worst = max(worst, float(np.abs(T[:3, 3] - 1000.0 * ref[:3, 3]).max()))
        assert np.abs(T[:3, :3] - ref[:3, :3]).max() < 1e-12
    assert worst < 1e-9, worst                                           # mm


def test_the_kinova_gripper_mimic_joints_are_refused_only_on_the_chain(tmp_path):
    path = REAL / "kinova_gen3_lite.urdf"
    with pytest.raises(RoboCalError, match="end links"):
        import_urdf(path)                                 # the fingers and the tool frame: which one?
    with pytest.raises(RoboCalError, match="mimic joint") as err:
        import_urdf(path, tip="right_finger_dist_link")
    assert err.value.field == "joint 'right_finger_tip_joint'"
    assert main(["robot-import", str(path), "--tip", "tool_frame", "--out", str(tmp_path / "gen3.json")]) == 0
    assert read_robot(tmp_path / "gen3.json").dof == 6


@pytest.mark.parametrize("name", [a[0] for a in ARMS])
def test_the_same_file_in_millimetres_or_with_the_base_as_tip_is_one_clear_line(tmp_path, capsys, name):
    import re
    text = (REAL / name).read_text()
    mm = tmp_path / name
    mm.write_text(re.sub(r'(<origin[^>]*xyz=")([^"]*)"', lambda m: m.group(1) + " ".join(
        f"{1000 * float(v):.9g}" for v in m.group(2).split()) + '"', text))
    tip = dict((a[0], a[1]) for a in ARMS)[name]
    args = ["robot-import", str(mm), "--out", str(tmp_path / "r.json")] + (["--tip", tip] if tip else [])
    assert main(args) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "look like millimetres" in err[0] and str(mm) in err[0], err
    base = import_urdf(REAL / name, tip=tip).base_link
    assert main(["robot-import", str(REAL / name), "--tip", base, "--out", str(tmp_path / "r.json")]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "is the base link" in err[0], err
    assert not (tmp_path / "r.json").exists()
