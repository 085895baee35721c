"""read_pose_list: a poses CSV to measure, in internal units, poses outside the limits kept."""
from __future__ import annotations

import numpy as np
import pytest

from core.errors import RoboCalError
from core.poses.file import read_pose_list, read_poses, write_poses
from core.robot.file import read_robot
from core.robot.model import robot_path


@pytest.fixture(scope="module")
def arm():
    return read_robot(robot_path("educational_6r"))


def test_joint_values_in_internal_units_and_out_of_limits_kept(arm, tmp_path):
    q_file = np.array([[10.0, -20.0, 30.0, 0.0, 45.0, -90.0],
                       [0.0, 400.0, 0.0, 0.0, 0.0, 0.0]])          # J2 far outside its limits
    path = write_poses(tmp_path / "poses.csv", q_file)
    with pytest.raises(RoboCalError, match="outside the joint limits"):
        read_poses(path, arm)
    poses = read_pose_list(path, arm)
    assert len(poses) == 2 and poses.pose.tolist() == [0, 1]
    np.testing.assert_allclose(poses.Q, np.radians(q_file), atol=1e-12)
    np.testing.assert_allclose(poses.q_file, q_file)


def test_another_joint_count_names_the_file_and_the_robot(arm, tmp_path):
    path = write_poses(tmp_path / "three.csv", np.zeros((2, 3)))
    with pytest.raises(RoboCalError) as info:
        read_pose_list(path, arm)
    msg = info.value.message
    assert "three.csv" in msg and "3 joint columns" in msg and f"has {arm.dof} joints" in msg
    assert "Use poses selected for this robot" in msg


def test_a_huge_joint_value_is_refused_in_the_joints_unit(arm, tmp_path):
    """A revolute joint's value is degrees: with the robot, 5000 is refused as more than ten
    turns (not as millimetres); without it, the unit is unknown and only values beyond any joint
    (1e308) are refused, without a unit."""
    path = write_poses(tmp_path / "poses.csv", np.array([[0.0, 0.0, 0.0, 5000.0, 0.0, 0.0]]))
    with pytest.raises(RoboCalError, match=r"line 2, q4.*5000 degrees is outside -3600 … 3600 degrees"):
        read_poses(path, arm)
    assert read_pose_list(path, arm).q_file[0, 3] == 5000.0                  # kept: the robot refuses it
    path.write_text("pose,q1,q2,q3,q4,q5,q6\n0,0,0,0,1e308,0,0\n")
    for read in (read_poses, lambda p: read_pose_list(p, arm)):
        with pytest.raises(RoboCalError) as info:
            read(path)
        assert "value 1e+308 is outside -100000 … 100000 (joint values are degrees or mm" in info.value.message
        assert " mm is outside" not in info.value.message
