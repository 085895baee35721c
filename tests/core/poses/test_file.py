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
