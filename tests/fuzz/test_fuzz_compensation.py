"""Fuzzing what `compensate` reads: the targets file, a nominal joint program, a fixture pose
file (--frame) and the robot files (--robot, --nominal). Exit 1 or 2 with one stderr line naming
the file and no file created or changed, or success where the mutation leaves a valid, reachable
input."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from core import transforms as tf
from core.fixtures.file import fixture_pose_dict
from core.fixtures.frame import FixtureFrame
from core.robot.model import robot_path
from tests.fuzz.cells import with_cell
from tests.fuzz.test_fuzz_commands import JUNK, assert_one_clear_line, mutate, robot_paths, run

FUZZ = settings(derandomize=True, max_examples=80, deadline=None, database=None,
                suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])

# the educational 6R arm's marker at (0, 10, 20, 0, 30, 0)° and (5, −10, 15, 10, 20, 5)°, base frame
TARGETS = ("name,x,y,z,roll,pitch,yaw,q1,q2,q3,q4,q5,q6\n"
           "a,139.25,0.0,375.45,0.0,-30.0,180.0,0,10,20,0,30,0\n"
           "b,236.08,14.99,279.16,-30.92,-60.88,-144.31,5,-10,15,10,20,5\n")


@FUZZ
@given(line=st.integers(0, 2), column=st.integers(0, 12),
       value=st.one_of(st.text(alphabet=" ,\"#x0123456789.e-+nq\n\r\x00\u2028", max_size=8),
                       st.sampled_from(["nan", "inf", "1e308", "-1e300", "", "1e20", "9" * 400, "-1", "0.5",
                                        "roll", "q7", "name"])))
def test_malformed_targets_for_compensate(tmp_path_factory, line, column, value):
    work = tmp_path_factory.mktemp("targets")
    targets = work / "targets.csv"
    targets.write_text(with_cell(TARGETS, line, column, value))
    code, err = run(["compensate", "--robot", str(robot_path("educational_6r")), "--targets", str(targets),
                     "--position-only", "--out", str(work / "j.csv")], work)
    if code != 0:
        assert_one_clear_line(code, err, [str(targets)])
    else:
        assert (work / "j.csv").is_file()


# -- the command's other inputs: joint programs, fixture pose files, robot files ------------------

ROBOT = robot_path("educational_6r")
PROGRAM = "pose,q1,q2,q3,q4,q5,q6\n1,0,10,20,0,30,0\n2,5,-10,15,10,20,5\n"


def _fixture_pose() -> dict:
    """A fixture pose file as locate-fixture writes it: a plate 250 mm ahead, turned 40°."""
    frame = FixtureFrame(tf.pose_to_matrix([250.0, -30.0, 10.0], np.deg2rad([0.0, 5.0, 40.0])), np.eye(6) * 1e-4,
                         "rigid fit", ["a", "b", "c"], np.eye(3), np.eye(3), np.zeros((3, 3)),
                         np.tile(np.eye(3) * 1e-4, (3, 1, 1)))
    return json.loads(json.dumps(fixture_pose_dict(frame, name="plate")))


FIXTURE_POSE = _fixture_pose()
#: the 6R arm's marker at (0, 10, 20, 0, 30, 0)° and (5, −10, 15, 10, 20, 5)° in that fixture's frame (mm)
FIXTURE_TARGETS = "name,x,y,z\na,-97.16,94.17,358.35\nb,-5.27,43.41,269.73\n"
ROBOT_JSON = json.loads(Path(ROBOT).read_text())
FAST = settings(FUZZ, max_examples=40)


@FAST
@given(line=st.integers(0, 2), column=st.integers(0, 6),
       value=st.one_of(st.text(alphabet=" ,\"#x0123456789.e-+nq\r\x00", max_size=8),
                       st.sampled_from(["nan", "inf", "1e308", "", "9" * 400, "-1", "pose", "q7", "720"])))
def test_malformed_joint_programs_for_compensate(tmp_path_factory, line, column, value):
    work = tmp_path_factory.mktemp("program")
    program = work / "program.csv"
    program.write_text(with_cell(PROGRAM, line, column, value))
    code, err = run(["compensate", "--robot", str(ROBOT), "--program", str(program), "--nominal", str(ROBOT),
                     "--position-only", "--out", str(work / "j.csv")], work)
    if code != 0:
        assert_one_clear_line(code, err, [str(program)])
        assert not (work / "j.csv").exists()
    else:
        assert (work / "j.csv").is_file()


@FAST
@given(where=st.sampled_from(list(robot_paths(FIXTURE_POSE))), value=JUNK)
def test_malformed_fixture_pose_files_for_compensate(tmp_path_factory, where, value):
    """--frame FIXTURE_POSE.json with a damaged field; the targets (base-frame numbers read in
    the fixture's frame) may be out of reach: a refusal naming the targets file is clear too."""
    work = tmp_path_factory.mktemp("frame")
    pose = work / "fixture_pose.json"
    pose.write_text(json.dumps(mutate(json.loads(json.dumps(FIXTURE_POSE)), where, value), allow_nan=True))
    targets = work / "targets.csv"
    targets.write_text(FIXTURE_TARGETS)
    code, err = run(["compensate", "--robot", str(ROBOT), "--targets", str(targets), "--frame", str(pose),
                     "--position-only", "--out", str(work / "j.csv")], work)
    if code != 0:
        assert_one_clear_line(code, err, [str(pose), str(targets)])
        assert not (work / "j.csv").exists()


@FAST
@given(where=st.sampled_from(list(robot_paths(ROBOT_JSON))), value=JUNK, which=st.sampled_from(["--robot", "--nominal"]))
def test_malformed_robot_files_for_compensate(tmp_path_factory, where, value, which):
    """The calibrated robot (--robot) or the controller's nominal one (--nominal) damaged."""
    work = tmp_path_factory.mktemp("robot")
    bad = work / "robot.json"
    bad.write_text(json.dumps(mutate(json.loads(json.dumps(ROBOT_JSON)), where, value), allow_nan=True))
    program = work / "program.csv"
    program.write_text(PROGRAM)
    robot, nominal = (bad, ROBOT) if which == "--robot" else (ROBOT, bad)
    code, err = run(["compensate", "--robot", str(robot), "--program", str(program), "--nominal", str(nominal),
                     "--position-only", "--out", str(work / "j.csv")], work)
    if code != 0:
        assert_one_clear_line(code, err, [str(bad), str(program)])
        assert not (work / "j.csv").exists()
