"""The targets file: written from its description and read, written and read back, bad files named."""
import numpy as np
import pytest

from core import transforms as tf
from core.compensation.targets import read_targets, write_targets
from core.errors import RoboCalError


def test_read_a_file_written_from_the_format(tmp_path):
    path = tmp_path / "t.csv"
    path.write_text("# a comment\n\nname,yaw,x,y,z,roll,pitch,q1,q2\np1,90,400,-35.5,310,180,0,10,-30\n"
                    "p 2,0,1,2,3,0,0,0,0\n")
    t = read_targets(path, dof=2)
    assert t.names == ["p1", "p 2"]
    assert np.allclose(t.xyz, [[400, -35.5, 310], [1, 2, 3]])
    assert np.allclose(t.rpy_deg[0], [180, 0, 90]) and np.allclose(t.hint_file[0], [10, -30])
    # R = Rz(yaw)·Ry(pitch)·Rx(roll), as robot.json's rpy
    assert np.allclose(t.rotations[0], tf.rot_z(np.pi / 2) @ tf.rot_x(np.pi))


def test_positions_only_and_round_trip(tmp_path):
    path = tmp_path / "t.csv"
    path.write_text("name,x,y,z\na,1,2,3\n")
    t = read_targets(path)
    assert t.rpy_deg is None and t.rotations is None and t.hint_file is None
    xyz = np.array([[1.2345678, -2.0, 3.0], [0.0, 1e-9, -5.5]])
    rpy = np.array([[10.0, -20.0, 30.5], [0.0, 0.0, 179.999999]])
    write_targets(tmp_path / "w.csv", ["a", "b"], xyz, rpy, np.array([[1.0, 2.0], [3.0, 4.0]]))
    back = read_targets(tmp_path / "w.csv", dof=2)
    assert back.names == ["a", "b"]
    assert np.abs(back.xyz - xyz).max() <= 5e-7 and np.abs(back.rpy_deg - rpy).max() <= 5e-7
    assert (tmp_path / "w.csv").read_text().splitlines()[2].startswith("b,0.000000,0.000000,-5.500000")


@pytest.mark.parametrize("text, message", [
    ("name,x,y\na,1,2\n", "no column 'z'"),
    ("name,x,y,z,roll,pitch\na,1,2,3,0,0\n", "no column 'yaw'"),
    ("name,x,y,z,q1,q3\na,1,2,3,0,0\n", "without a gap"),
    ("name,x,y,z,q1\na,1,2,3,0\n", "1 joint columns but the robot has 2"),
    ("name,x,y,z,speed\na,1,2,3,0\n", "unexpected or repeated column 'speed'"),
    ("name,x,y,z\na,1,2\n", "line 2: expected 4 values, got 3"),
    ("name,x,y,z\na,1,two,3\n", "line 2, column 'y': expected a number, got 'two'"),
    ("name,x,y,z\n,1,2,3\n", "column 'name': empty"),
    ("name,x,y,z\na,1,2,1e9\n", "outside"),
    ("name,x,y,z\n", "no targets"),
    ("", "empty file"),
])
def test_bad_files_are_named(tmp_path, text, message):
    path = tmp_path / "bad.csv"
    path.write_text(text)
    with pytest.raises(RoboCalError, match=message) as info:
        read_targets(path, dof=2)
    assert "bad.csv" in str(info.value)


def test_a_name_that_cannot_be_written(tmp_path):
    with pytest.raises(RoboCalError, match="cannot be written"):
        write_targets(tmp_path / "w.csv", ["a,b"], np.zeros((1, 3)))
    assert not (tmp_path / "w.csv").exists()
