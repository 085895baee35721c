"""measurements.csv: reading, validation messages (file, line, column), writing, appending."""
from __future__ import annotations

import re

import numpy as np
import pytest

from core.errors import RoboCalError
from core.robot.model import robot_path
from core.measurement.file import (TAG_LINE, MeasurementWriter, Measurements, check_against_robot, header_columns,
                               read_measurements, write_measurements)
from core.robot.file import read_robot

HEADER = "pose,target,q1,q2,q3,q4,q5,q6,x,y,z"


@pytest.fixture(scope="module")
def robot():
    return read_robot(robot_path("educational_6r"))


def write(tmp_path, body: str, name="m.csv"):
    path = tmp_path / name
    path.write_text(body, encoding="utf-8")
    return path


def test_reads_the_design_example(tmp_path, robot):
    path = write(tmp_path, f"{TAG_LINE}\n{HEADER}\n0,marker,10.0,-35.2,20.1,0.0,45.0,0.0,412.31,-20.55,815.02\n")
    m = read_measurements(path, robot)
    assert m.n_points == 1 and m.n_poses == 1 and m.target == ["marker"]
    np.testing.assert_allclose(m.q_file[0], [10.0, -35.2, 20.1, 0.0, 45.0, 0.0])
    np.testing.assert_allclose(m.Q[0], np.deg2rad([10.0, -35.2, 20.1, 0.0, 45.0, 0.0]))
    np.testing.assert_allclose(m.xyz[0], [412.31, -20.55, 815.02])
    assert m.sigma is None and m.line.tolist() == [3] and m.source == str(path)


def test_comments_blank_lines_sigmas_and_several_targets(tmp_path, robot):
    robot = robot.copy()
    robot.targets["tip"] = np.array([0.0, 10.0, 30.0])
    body = (f"# robocal.measurements/1.0 ; produced by hand\n# another comment\n\n"
            f"{HEADER},sx,sy,sz\n"
            "0,marker,1,2,3,4,5,6,10,20,30,0.1,0.1,0.2\n"
            "# a comment between rows\n"
            "0,tip,1,2,3,4,5,6,11,21,31,0.1,0.1,0.2\n"
            "7,tip,0,0,0,0,0,0,1,2,3,0.05,0.05,0.05\n")
    m = read_measurements(write(tmp_path, body), robot)
    assert m.pose.tolist() == [0, 0, 7] and m.target == ["marker", "tip", "tip"]
    assert m.pose_ids.tolist() == [0, 7] and m.target_names == ["marker", "tip"]
    np.testing.assert_allclose(m.sigma[2], [0.05, 0.05, 0.05])
    assert m.line.tolist() == [5, 7, 8]
    assert m.select_poses([7]).n_points == 1


def test_round_trip_write_read(tmp_path, robot):
    rng = np.random.default_rng(1)
    m = Measurements(pose=[0, 1, 2], target=["marker"] * 3, q_file=rng.uniform(-90, 90, (3, 6)),
                     xyz=rng.uniform(-500, 500, (3, 3)), sigma=np.full((3, 3), 0.05))
    path = write_measurements(m, tmp_path / "out" / "m.csv")
    back = read_measurements(path, robot)
    np.testing.assert_allclose(back.q_file, m.q_file, atol=1e-6)
    np.testing.assert_allclose(back.xyz, m.xyz, atol=1e-6)
    np.testing.assert_allclose(back.sigma, m.sigma)
    assert path.read_text().splitlines()[0] == TAG_LINE


@pytest.mark.parametrize("cell, expected", [
    ("nan", "line 3, column 'y': expected a finite number, got 'nan'"),
    ("inf", "line 3, column 'y': expected a finite number"),
    ("abc", "line 3, column 'y': expected a number, got the text 'abc'"),
    ("", "line 3, column 'y': expected a number, got an empty cell"),
    ("1,5", "line 3: expected 11 values"),
])
def test_bad_number_names_file_line_and_column(tmp_path, robot, cell, expected):
    path = write(tmp_path, f"{TAG_LINE}\n{HEADER}\n0,marker,1,2,3,4,5,6,10,{cell},30\n")
    with pytest.raises(RoboCalError) as err:
        read_measurements(path, robot)
    assert str(path) in err.value.message and expected in err.value.message


def test_text_in_a_joint_column(tmp_path, robot):
    path = write(tmp_path, f"{TAG_LINE}\n{HEADER}\n0,marker,1,2,3,4,5,6,10,20,30\n1,marker,1,two,3,4,5,6,10,20,30\n")
    with pytest.raises(RoboCalError, match=r"line 4, column 'q2': expected a number, got the text 'two'"):
        read_measurements(path, robot)


def test_wrong_joint_count_vs_robot(tmp_path, robot):
    path = write(tmp_path, f"{TAG_LINE}\npose,target,q1,q2,q3,q4,q5,x,y,z\n0,marker,1,2,3,4,5,10,20,30\n")
    with pytest.raises(RoboCalError, match=r"line 2: the file has 5 joint columns \(q1..q5\) but the robot has 6 joints"):
        read_measurements(path, robot)
    assert read_measurements(path).dof == 5   # without a robot the file itself is fine


@pytest.mark.parametrize("header, expected", [
    ("pose,target,q1,q2,q3,q4,q5,q6,x,y", "missing column 'z'"),
    ("pose,q1,q2,q3,q4,q5,q6,x,y,z", "missing column 'target'"),
    ("pose,target,x,y,z", "no joint columns"),
    ("pose,target,q1,q3,q4,q5,q6,q7,x,y,z", "must be q1..q6; missing q2"),
    ("pose,target,q1,q2,q3,q4,q5,q6,x,y,z,sx,sy", "missing column 'sz'"),
    ("pose,target,q1,q2,q3,q4,q5,q6,x,y,z,s_x", "unknown column 's_x'"),
    ("pose,target,q1,q2,q3,q4,q5,q6,x,x,y,z", "the column 'x' appears twice"),
])
def test_bad_header(tmp_path, header, expected):
    path = write(tmp_path, f"{TAG_LINE}\n{header}\n")
    with pytest.raises(RoboCalError, match=re.escape(expected)):
        read_measurements(path)


def test_unknown_columns_are_ignored_in_a_later_minor_version(tmp_path, robot):
    path = write(tmp_path, f"# robocal.measurements/1.3\n{HEADER},quality\n0,marker,1,2,3,4,5,6,10,20,30,good\n")
    assert read_measurements(path, robot).n_points == 1


@pytest.mark.parametrize("first, expected", [
    ("# robocal.measurements/2", "unknown format version 2 (this RoboCal reads version 1)"),
    ("# robocal.measurements/x", "bad format version 'x'"),
    ("# just a comment", "must carry the format tag 'robocal.measurements/1'"),
])
def test_format_tag(tmp_path, first, expected):
    path = write(tmp_path, f"{first}\n{HEADER}\n0,marker,1,2,3,4,5,6,10,20,30\n")
    with pytest.raises(RoboCalError, match=re.escape(expected)) as err:
        read_measurements(path)
    assert "line 1" in err.value.message


def test_missing_tag_line_and_empty_files(tmp_path):
    with pytest.raises(RoboCalError, match="line 1: the file must start with the format tag line"):
        read_measurements(write(tmp_path, f"{HEADER}\n0,marker,1,2,3,4,5,6,10,20,30\n"))
    with pytest.raises(RoboCalError, match="empty file"):
        read_measurements(write(tmp_path, "\n\n"))
    with pytest.raises(RoboCalError, match="no measurements"):
        read_measurements(write(tmp_path, f"{TAG_LINE}\n{HEADER}\n"))
    with pytest.raises(RoboCalError, match="file not found"):
        read_measurements(tmp_path / "nope.csv")


def test_target_not_in_robot_is_named(tmp_path, robot):
    path = write(tmp_path, f"{TAG_LINE}\n{HEADER}\n0,marker,1,2,3,4,5,6,10,20,30\n1,probe,1,2,3,4,5,6,10,20,30\n")
    meas = read_measurements(path, robot)          # reading checks the joints; identification estimates 'probe'
    with pytest.raises(RoboCalError, match=r"line 4: target 'probe' is not defined in the robot .*its targets: marker"):
        check_against_robot(meas, robot)


def test_inconsistent_pose_duplicates_and_bad_sigma(tmp_path, robot):
    robot = robot.copy()
    robot.targets["tip"] = np.zeros(3)
    path = write(tmp_path, f"{TAG_LINE}\n{HEADER}\n0,marker,1,2,3,4,5,6,10,20,30\n0,tip,1,2,3,4,5,7,10,20,30\n")
    with pytest.raises(RoboCalError, match="line 4: pose 0 has other joint values than on line 3"):
        read_measurements(path, robot)
    path = write(tmp_path, f"{TAG_LINE}\n{HEADER}\n0,marker,1,2,3,4,5,6,10,20,30\n0,marker,1,2,3,4,5,6,10,20,30\n")
    with pytest.raises(RoboCalError, match="line 4: pose 0 target 'marker' was already measured on line 3"):
        read_measurements(path, robot)
    path = write(tmp_path, f"{TAG_LINE}\n{HEADER},sx,sy,sz\n0,marker,1,2,3,4,5,6,10,20,30,0.1,0,0.1\n")
    with pytest.raises(RoboCalError, match="line 3, column 'sy': a standard deviation must be positive"):
        read_measurements(path, robot)
    path = write(tmp_path, f"{TAG_LINE}\n{HEADER}\n1.5,marker,1,2,3,4,5,6,10,20,30\n")
    with pytest.raises(RoboCalError, match="line 3, column 'pose': expected a whole number"):
        read_measurements(path, robot)


def test_writer_appends_and_flushes_each_row(tmp_path, robot):
    path = tmp_path / "run" / "m.csv"
    with MeasurementWriter(path, dof=6) as w:
        w.append(0, "marker", [1, 2, 3, 4, 5, 6], [10, 20, 30])
        # flushed to disk at once: readable while the writer is still open
        assert read_measurements(path, robot).n_points == 1
        w.append(1, "marker", [0, 0, 0, 0, 0, 0], [11, 21, 31])
    assert read_measurements(path, robot).n_points == 2
    # a second run appends to the same file (no second header)
    with MeasurementWriter(path, dof=6) as w:
        w.append(2, "marker", [0, 1, 0, 0, 0, 0], [12, 22, 32])
    m = read_measurements(path, robot)
    assert m.pose.tolist() == [0, 1, 2]
    assert path.read_text().count("pose,target") == 1


def test_writer_recovers_from_a_partial_last_line_and_checks_the_header(tmp_path, robot):
    path = tmp_path / "m.csv"
    path.write_text(f"{TAG_LINE}\n{HEADER}\n0,marker,1,2,3,4,5,6,10,20,30\n1,marker,1,2,")   # crash mid-row
    with MeasurementWriter(path, dof=6) as w:
        w.append(2, "marker", [0, 0, 0, 0, 0, 0], [1, 2, 3])
    lines = path.read_text().splitlines()
    assert lines[-1].startswith("2,marker,") and lines[-2].startswith("0,marker,")
    meas = read_measurements(path, robot)         # the half-written row is cut off, not kept
    assert meas.pose.tolist() == [0, 2]
    with pytest.raises(RoboCalError, match="differ from the ones to write"):
        MeasurementWriter(path, dof=6, sigmas=True)
    with pytest.raises(RoboCalError, match="not a finite number"):
        with MeasurementWriter(tmp_path / "n.csv", dof=6) as w:
            w.append(0, "marker", [0, 0, 0, 0, 0, float("nan")], [1, 2, 3])
    assert header_columns(2, True) == ["pose", "target", "q1", "q2", "x", "y", "z", "sx", "sy", "sz"]


def test_writer_uses_fsync(tmp_path, monkeypatch):
    import core.measurement.appended_file as mod
    calls = []
    monkeypatch.setattr(mod.os, "fsync", lambda fd: calls.append(fd))
    with MeasurementWriter(tmp_path / "m.csv", dof=1) as w:
        n0 = len(calls)
        w.append(0, "marker", [1.0], [1, 2, 3])
        assert len(calls) == n0 + 1
