"""core.poses.visibility: marker visible in both images, facing the cameras, at a usable depth."""
from __future__ import annotations

import numpy as np
import pytest

from core import transforms as tf
from core.robot.model import Joint, RobotModel
from core.virtual_lab.rig import default_rig
from core.poses.visibility import marker_visibility, visible_mask

RIG = default_rig(0, misalignment=False)


def turntable(base_xyz, target=(0.0, 0.0, 20.0)) -> RobotModel:
    """One revolute joint about the camera's −y axis (vertical); at q = 0 the tool z axis
    points at the cameras (camera −z)."""
    # Base frame: z along camera −y (up), x along camera −z (towards the cameras).
    R = np.column_stack([[0.0, 0.0, -1.0], [1.0, 0.0, 0.0], [0.0, -1.0, 0.0]])
    base = tf.make_transform(R, base_xyz)
    # Tool: z along base x (towards the cameras).
    tool = tf.make_transform(tf.rot_y(np.pi / 2) @ tf.rot_z(np.pi / 2), [50.0, 0.0, 0.0])
    joint = Joint(theta=0.0, d=0.0, a=0.0, alpha=0.0, min=-np.pi, max=np.pi)
    return RobotModel("turntable", [joint], base=base, tool=tool, targets={"marker": np.array(target)})


def test_turntable_tool_faces_the_cameras_at_zero():
    robot = turntable([65.0, 0.0, 650.0])
    T = robot.fk([0.0])
    assert np.allclose(T[:3, 2], [0.0, 0.0, -1.0])


def test_facing_angle_limits_visibility():
    robot = turntable([65.0, 0.0, 650.0])
    Q = np.deg2rad([[0.0], [40.0], [-40.0], [75.0], [120.0], [180.0]])
    vis = marker_visibility(Q, robot, RIG, 60.0)
    assert vis.visible.tolist() == [True, True, True, False, False, False]
    assert vis.in_left[:3].all() and vis.depth_ok[:3].all()
    assert vis.facing.tolist() == [True, True, True, False, False, False]
    # Angles are measured to each camera: the right camera sees the plate at another angle.
    assert not np.allclose(vis.angle_left, vis.angle_right)
    wide = marker_visibility(Q, robot, RIG, 60.0, max_angle_deg=89.0)
    assert wide.visible[3]


@pytest.mark.parametrize("depth, ok", [(300.0, False), (500.0, True), (950.0, True), (1200.0, False)])
def test_depth_range(depth, ok):
    robot = turntable([65.0, 0.0, depth + 70.0])     # marker 70 mm in front of the base
    vis = marker_visibility(np.zeros((1, 1)), robot, RIG, 40.0)
    assert np.isclose(vis.depth[0], depth)
    assert bool(vis.depth_ok[0]) == ok
    assert bool(vis.visible[0]) == ok
    assert bool(marker_visibility(np.zeros((1, 1)), robot, RIG, 40.0, min_depth=100, max_depth=2000).visible[0])


def test_left_only_right_only_and_margin():
    f = RIG.left.fx
    depth = 600.0
    # Marker near the left border of the left image: the right camera sees it further left.
    u_left = 120.0
    x = (u_left - RIG.left.cx) / f * depth
    robot = turntable([x, 0.0, depth + 70.0])
    vis = marker_visibility(np.zeros((1, 1)), robot, RIG, 40.0)
    assert vis.in_left[0] and not vis.in_right[0] and not vis.visible[0]
    # Near the right border of the right image: the left camera sees it further right.
    x = RIG.right_centre[0] + (RIG.right.width - 120.0 - RIG.right.cx) / f * depth
    robot = turntable([x, 0.0, depth + 70.0])
    vis = marker_visibility(np.zeros((1, 1)), robot, RIG, 40.0)
    assert vis.in_right[0] and not vis.in_left[0]
    # The plate corners count, not only the centre: a big plate near a border is cut off.
    x = (60.0 - RIG.left.cx) / f * depth + RIG.right_centre[0]
    robot = turntable([x, 0.0, depth + 70.0])
    small = marker_visibility(np.zeros((1, 1)), robot, RIG, 10.0, margin=5.0)
    big = marker_visibility(np.zeros((1, 1)), robot, RIG, 60.0, margin=5.0)
    assert small.in_right[0] and not big.in_right[0]
    stricter = marker_visibility(np.zeros((1, 1)), robot, RIG, 10.0, margin=100.0)
    assert not stricter.in_right[0]


def test_behind_the_cameras_is_not_visible():
    robot = turntable([65.0, 0.0, -600.0])
    vis = marker_visibility(np.zeros((1, 1)), robot, RIG, 40.0)
    assert not vis.in_left[0] and not vis.in_right[0] and not vis.visible[0]


def test_vectorised_and_consistent_with_single_calls():
    robot = turntable([65.0, 30.0, 650.0])
    Q = np.linspace(-np.pi, np.pi, 73)[:, None]
    mask = visible_mask(Q, robot, RIG, (40.0, 30.0))
    assert mask.shape == (73,) and mask.dtype == bool
    single = [bool(visible_mask(q[None, :], robot, RIG, (40.0, 30.0))[0]) for q in Q]
    assert mask.tolist() == single
    assert 0 < mask.sum() < 73
