"""core.robot.urdf_import: a URDF chain to DH + base + tool, with the same forward kinematics."""
from __future__ import annotations

import numpy as np
import pytest

from core.errors import RoboCalError
from core.robot.urdf_import import import_urdf, urdf_forward_kinematics

# The UR5 as ROS-Industrial's ur_description describes it (ur5.urdf.xacro, metres and radians)
UR5 = """<?xml version="1.0"?>
<robot name="ur5">
  <link name="base_link"/><link name="shoulder_link"/><link name="upper_arm_link"/><link name="forearm_link"/>
  <link name="wrist_1_link"/><link name="wrist_2_link"/><link name="wrist_3_link"/><link name="ee_link"/>
  <joint name="shoulder_pan_joint" type="revolute"><parent link="base_link"/><child link="shoulder_link"/>
    <origin xyz="0 0 0.089159" rpy="0 0 0"/><axis xyz="0 0 1"/><limit lower="-6.2832" upper="6.2832" effort="150" velocity="3.15"/></joint>
  <joint name="shoulder_lift_joint" type="revolute"><parent link="shoulder_link"/><child link="upper_arm_link"/>
    <origin xyz="0 0.13585 0" rpy="0 1.570796325 0"/><axis xyz="0 1 0"/><limit lower="-6.2832" upper="6.2832" effort="150" velocity="3.15"/></joint>
  <joint name="elbow_joint" type="revolute"><parent link="upper_arm_link"/><child link="forearm_link"/>
    <origin xyz="0 -0.1197 0.425" rpy="0 0 0"/><axis xyz="0 1 0"/><limit lower="-3.1416" upper="3.1416" effort="150" velocity="3.15"/></joint>
  <joint name="wrist_1_joint" type="revolute"><parent link="forearm_link"/><child link="wrist_1_link"/>
    <origin xyz="0 0 0.39225" rpy="0 1.570796325 0"/><axis xyz="0 1 0"/><limit lower="-6.2832" upper="6.2832" effort="28" velocity="3.2"/></joint>
  <joint name="wrist_2_joint" type="revolute"><parent link="wrist_1_link"/><child link="wrist_2_link"/>
    <origin xyz="0 0.093 0" rpy="0 0 0"/><axis xyz="0 0 1"/><limit lower="-6.2832" upper="6.2832" effort="28" velocity="3.2"/></joint>
  <joint name="wrist_3_joint" type="revolute"><parent link="wrist_2_link"/><child link="wrist_3_link"/>
    <origin xyz="0 0 0.09465" rpy="0 0 0"/><axis xyz="0 1 0"/><limit lower="-6.2832" upper="6.2832" effort="28" velocity="3.2"/></joint>
  <joint name="ee_fixed_joint" type="fixed"><parent link="wrist_3_link"/><child link="ee_link"/>
    <origin xyz="0 0.0823 0" rpy="0 0 1.570796325"/></joint>
</robot>
"""

# an arm with a prismatic lift, a continuous joint, a fixed bracket in the middle and a tilted base
ODD = """<robot name="odd">
  <link name="world"/><link name="base"/><link name="l1"/><link name="l2"/><link name="bracket"/><link name="l3"/><link name="tool"/>
  <joint name="mount" type="fixed"><parent link="world"/><child link="base"/><origin xyz="0.1 -0.2 0.05" rpy="0.1 -0.2 0.3"/></joint>
  <joint name="lift" type="prismatic"><parent link="base"/><child link="l1"/><origin xyz="0 0 0.3"/><axis xyz="0 0 1"/>
    <limit lower="0" upper="0.5" effort="1" velocity="1"/></joint>
  <joint name="turn" type="continuous"><parent link="l1"/><child link="l2"/><origin xyz="0.2 0.05 0" rpy="0 0.3 0"/><axis xyz="0 0 -1"/></joint>
  <joint name="fix" type="fixed"><parent link="l2"/><child link="bracket"/><origin xyz="0.1 0 0.02" rpy="0.2 0 0"/></joint>
  <joint name="wrist" type="revolute"><parent link="bracket"/><child link="l3"/><origin xyz="0 0.1 0"/><axis xyz="1 1 0"/>
    <limit lower="-2" upper="2" effort="1" velocity="1"/></joint>
  <joint name="flange" type="fixed"><parent link="l3"/><child link="tool"/><origin xyz="0.03 0.01 0.12" rpy="0 0 0.5"/></joint>
</robot>
"""


def random_q(model, n, rng):
    lo, hi = model.limits()
    return rng.uniform(np.maximum(lo, -2 * np.pi), np.minimum(hi, 2 * np.pi), size=(n, model.dof))


@pytest.mark.parametrize("text, dof", [(UR5, 6), (ODD, 3)])
def test_forward_kinematics_equal_on_1000_configurations(tmp_path, text, dof):
    path = tmp_path / "robot.urdf"
    path.write_text(text)
    imported = import_urdf(path)
    model = imported.model
    assert model.dof == dof
    for q in random_q(model, 1000, np.random.default_rng(1)):
        ref = urdf_forward_kinematics(path, q)
        T = model.fk(q)
        assert np.abs(T[:3, 3] - ref[:3, 3]).max() < 1e-6            # mm
        assert np.abs(T[:3, :3] - ref[:3, :3]).max() < 1e-9


def test_against_yourdfpy_and_the_published_ur5_zero_pose(tmp_path):
    yourdfpy = pytest.importorskip("yourdfpy")
    path = tmp_path / "ur5.urdf"
    path.write_text(UR5)
    model = import_urdf(path).model
    assert [j.name for j in model.joints][:2] == ["shoulder_pan_joint", "shoulder_lift_joint"]
    urdf = yourdfpy.URDF.load(str(path), load_meshes=False, build_scene_graph=True)
    for q in random_q(model, 200, np.random.default_rng(2)):
        urdf.update_cfg(q)
        ref = urdf.get_transform("ee_link", "base_link")
        assert np.abs(model.fk(q)[:3, 3] - 1000 * ref[:3, 3]).max() < 1e-6
    # UR5 published zero pose of the flange (standard DH, mm): x = a2 + a3 = -817.25, y = -(d4 + d6) = -191.45,
    # z = d1 - d5 = -5.491; ROS's base_link is turned 180° about z against UR's DH base frame, so x and y flip.
    # (1e-5 mm: the URDF writes pi/2 as 1.570796325.)
    np.testing.assert_allclose(model.fk(np.zeros(6))[:3, 3], [817.25, 191.45, -5.491], atol=1e-5)


def test_chains_dh_cannot_express_are_refused(tmp_path):
    closed = UR5.replace('<joint name="ee_fixed_joint" type="fixed"><parent link="wrist_3_link"/>',
                         '<joint name="loop" type="fixed"><parent link="base_link"/><child link="wrist_3_link"/></joint>'
                         '<joint name="ee_fixed_joint" type="fixed"><parent link="wrist_3_link"/>')
    cases = [(closed, "not a tree"),
             (UR5.replace('type="revolute"><parent link="wrist_2_link"/>', 'type="floating"><parent link="wrist_2_link"/>'),
              "floating joint"),
             (UR5.replace('<axis xyz="0 0 1"/><limit lower="-6.2832" upper="6.2832" effort="28"',
                          '<axis xyz="0 0 1"/><mimic joint="wrist_1_joint"/><limit lower="-6.2832" upper="6.2832" effort="28"'),
              "mimic joint"),
             ("<robot name='x'><link name='a'/>", "not a readable URDF")]
    for text, says in cases:
        path = tmp_path / "bad.urdf"
        path.write_text(text)
        with pytest.raises(RoboCalError, match=says) as info:
            import_urdf(path)
        assert "bad.urdf" in str(info.value)
    path = tmp_path / "ur5.urdf"
    path.write_text(UR5)
    with pytest.raises(RoboCalError, match="no link named 'flange'"):
        import_urdf(path, tip="flange")
    with pytest.raises(RoboCalError, match="is not below link"):
        import_urdf(path, base="wrist_1_link", tip="shoulder_link")



# the UR5 with its elbow and wrist 1 axes 0.01° off parallel (as rounding in a URDF leaves them)
TILT = "0.000174533"                                       # 0.01° in rad
UR5_ROUNDED = (UR5.replace('<origin xyz="0 -0.1197 0.425" rpy="0 0 0"/>', f'<origin xyz="0 -0.1197 0.425" rpy="{TILT} 0 0"/>')
               .replace('<origin xyz="0 0 0.39225" rpy="0 1.570796325 0"/>',
                        f'<origin xyz="0 0 0.39225" rpy="0 1.570796325 {TILT}"/>'))


def test_nearly_parallel_axes_take_hayatis_form(tmp_path):
    """Axes 0.01° off parallel: no common normal kilometres away (plain DH would put d2 at
    about 2.4 km) but Hayati's d = 0 with the tilt in β, and the same forward kinematics."""
    yourdfpy = pytest.importorskip("yourdfpy")
    assert UR5_ROUNDED.count(TILT) == 2
    path = tmp_path / "ur5_rounded.urdf"
    path.write_text(UR5_ROUNDED)
    imported = import_urdf(path)
    model = imported.model
    lengths = np.array([[j.d, j.a] for j in model.joints])
    assert np.abs(lengths).max() < 500                           # mm: the UR5's own lengths (a2 = 425)
    tilts = [np.rad2deg(np.arccos(np.cos(j.alpha) * np.cos(j.beta))) for j in model.joints[1:3]]
    np.testing.assert_allclose(tilts, 0.01, rtol=1e-3)           # deg between axes 2-3 and 3-4 (Rx(α)·Ry(β))
    assert [j.d for j in model.joints[1:3]] == [0.0, 0.0]
    assert model.parallel_axis_joints() == [1, 2]                 # identification swaps d for β here too
    assert any("within 5° of parallel" in n and "'shoulder_lift_joint'" in n for n in imported.notes)
    urdf = yourdfpy.URDF.load(str(path), load_meshes=False, build_scene_graph=True)
    for q in random_q(model, 200, np.random.default_rng(3)):
        urdf.update_cfg(q)
        ref = urdf.get_transform("ee_link", "base_link")
        T = model.fk(q)
        assert np.abs(T[:3, 3] - 1000 * ref[:3, 3]).max() < 1e-6          # mm
        assert np.abs(T[:3, :3] - ref[:3, :3]).max() < 1e-9
    for q in random_q(model, 1000, np.random.default_rng(4)):
        assert np.abs(model.fk(q)[:3, 3] - urdf_forward_kinematics(path, q)[:3, 3]).max() < 1e-6


def _ur5_in_mm() -> str:
    """UR5 with every origin length written in millimetres (the mistake: URDF lengths are metres)."""
    import re
    return re.sub(r'xyz="([^"]*)" rpy', lambda m: 'xyz="' + " ".join(f"{1000 * float(v):g}" for v in m.group(1).split())
                  + '" rpy', UR5)


XACRO = """<?xml version="1.0"?>
<robot xmlns:xacro="http://ros.org/wiki/xacro" name="arm">
  <xacro:property name="d1" value="0.089159"/>
  <xacro:macro name="arm" params="prefix">
    <link name="${prefix}base_link"/>
  </xacro:macro>
  <xacro:arm prefix=""/>
</robot>
"""

LOOP = """<robot name="loop"><link name="a"/><link name="b"/><link name="c"/>
  <joint name="j1" type="revolute"><parent link="a"/><child link="b"/><axis xyz="0 0 1"/><limit lower="-1" upper="1"/></joint>
  <joint name="j2" type="revolute"><parent link="b"/><child link="c"/><axis xyz="0 0 1"/><limit lower="-1" upper="1"/></joint>
  <joint name="j3" type="fixed"><parent link="c"/><child link="a"/></joint>
</robot>"""

GRIPPER = UR5.replace("</robot>", """
  <link name="finger_left"/><link name="finger_right"/>
  <joint name="finger_left_joint" type="prismatic"><parent link="ee_link"/><child link="finger_left"/>
    <origin xyz="0 0 0.05"/><axis xyz="0 1 0"/><limit lower="0" upper="0.04" effort="1" velocity="1"/></joint>
  <joint name="finger_right_joint" type="prismatic"><parent link="ee_link"/><child link="finger_right"/>
    <origin xyz="0 0 0.05"/><axis xyz="0 -1 0"/><limit lower="0" upper="0.04" effort="1" velocity="1"/>
    <mimic joint="finger_left_joint"/></joint>
</robot>""")


@pytest.mark.parametrize("text, kwargs, says, field", [
    (_ur5_in_mm(), {}, "these look like millimetres", "joint origin xyz"),
    (XACRO, {}, "unexpanded xacro file", None),
    (XACRO.replace(' xmlns:xacro="http://ros.org/wiki/xacro"', ""), {}, "unexpanded xacro file", None),
    (LOOP, {}, "a kinematic loop between the links 'a', 'c', 'b'", "joint 'j3'"),
    (UR5, {"tip": "base_link"}, "is the base link", "--tip"),
    (GRIPPER, {"tip": "finger_right"}, "mimic joint", "joint 'finger_right_joint'"),
    ("<robot name='empty'><link name='a'/></robot>", {}, "no joints", None),
])
def test_files_whose_problem_is_named(tmp_path, text, kwargs, says, field):
    path = tmp_path / "robot.urdf"
    path.write_text(text)
    with pytest.raises(RoboCalError, match=says) as info:
        import_urdf(path, **kwargs)
    assert info.value.source == str(path) and info.value.field == field


def test_a_mimic_joint_off_the_chain_is_ignored(tmp_path):
    path = tmp_path / "gripper.urdf"
    path.write_text(GRIPPER)
    with pytest.raises(RoboCalError, match="end links"):          # the fingers: which one is the tip?
        import_urdf(path)
    reference = tmp_path / "ur5.urdf"
    reference.write_text(UR5)
    model, plain = import_urdf(path, tip="ee_link").model, import_urdf(reference).model
    assert model.dof == 6
    for q in random_q(model, 50, np.random.default_rng(4)):
        np.testing.assert_allclose(model.fk(q), plain.fk(q), atol=1e-12)
        np.testing.assert_allclose(model.fk(q), urdf_forward_kinematics(path, q, tip="ee_link"), atol=1e-9)
