"""Fuzzing the inputs test_fuzz_commands.py leaves out: robot files read by `evaluate`, pose
files read by `measure --joints`, and the calibration section of calibrated robot files read by
`export` (both formats). Same rule: exit 1 or 2, one stderr line naming the file, no traceback,
no file created or changed; or success where the mutation leaves a valid file.
"""
from __future__ import annotations

import json
from pathlib import Path

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from core.robot.model import robot_path
from tests.fuzz.cells import with_cell
from tests.fuzz.test_fuzz_commands import JUNK, ROBOT, ROBOT_FIELDS, assert_one_clear_line, mutate, robot_paths, run

FUZZ = settings(derandomize=True, max_examples=80, deadline=None, database=None,
                suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])


@FUZZ
@given(where=st.sampled_from(ROBOT_FIELDS), value=JUNK)
def test_malformed_robot_files_for_evaluate(files, tmp_path_factory, where, value):
    work = tmp_path_factory.mktemp("eval")
    robot = work / "robot.json"
    robot.write_text(json.dumps(mutate(json.loads(Path(ROBOT).read_text()), where, value), allow_nan=True))
    code, err = run(["evaluate", "--robot", str(robot), "--measurements", str(files / "m.csv"), "--register-base"],
                    work)
    if code != 0:
        assert_one_clear_line(code, err, [str(robot)])


POSES = "pose,q1,q2,q3,q4,q5,q6\n0,-15.372,-13.685,-19.040,-66.447,70.177,-152.185\n1,-94.5,-4.1,54.8,84.4,-60.1,-157.2\n"


@FUZZ
@given(line=st.integers(0, 2), column=st.integers(0, 7),
       value=st.one_of(st.text(alphabet=" ,\"#x0123456789.e-+n\n\r\x00\u2028", max_size=8),
                       st.sampled_from(["nan", "inf", "1e308", "-1e300", "", "1e20", "9" * 400, "-1", "0.5"])))
def test_malformed_pose_files_for_measure(tmp_path_factory, line, column, value):
    """`measure --joints`: the pose file is read (with the robot) before any image; an images
    folder with no pairs makes every valid file end in the pairs-versus-poses refusal."""
    work = tmp_path_factory.mktemp("joints")
    joints = work / "joints.csv"
    joints.write_text(with_cell(POSES, line, column, value))
    images = work / "images"
    (images / "left").mkdir(parents=True)
    (images / "right").mkdir()
    code, err = run(["measure", "--stereo", str(work / "stereo.yaml"), "--marker", str(work / "marker.png"),
                     "--images", str(images), "--joints", str(joints), "--robot", str(robot_path("educational_6r")),
                     "--out", str(work / "m.csv")], work)
    assert_one_clear_line(code, err, [str(joints), str(images)])


CALIBRATED = None


def calibrated(files) -> dict:
    """A calibrated robot file (identify on the fuzz measurements), made once."""
    global CALIBRATED
    if CALIBRATED is None:
        out = files / "calibrated.json"
        if not out.exists():
            code, err = run(["identify", "--robot", str(ROBOT), "--measurements", str(files / "m.csv"), "--out",
                             str(out)], files)
            assert code == 0, err
        CALIBRATED = json.loads(out.read_text())
    return json.loads(json.dumps(CALIBRATED))


@FUZZ
@given(data=st.data(), value=JUNK, fmt=st.sampled_from(["dh-csv", "urdf"]))
def test_malformed_calibration_sections_for_export(files, tmp_path_factory, data, value, fmt):
    work = tmp_path_factory.mktemp("export")
    cal = calibrated(files)
    where = data.draw(st.sampled_from([("calibration",) + p for p in robot_paths(cal["calibration"])]
                                      + [("calibration",)]))
    robot = work / "cal.json"
    robot.write_text(json.dumps(mutate(cal, where, value), allow_nan=True))
    out = work / "out.txt"
    code, err = run(["export", "--robot", str(robot), "--format", fmt, "--out", str(out)], work)
    if code != 0:
        assert_one_clear_line(code, err, [str(robot)])
        assert not out.exists()


def _with_compliance() -> dict:
    """The fuzz robot with a deflection section as docs/file-formats.md writes it."""
    data = json.loads(Path(ROBOT).read_text())
    data["compliance"] = {"format": "robocal.compliance/1", "unit": "deg", "gravity": [0, 0, -1],
                          "joints": {"J2": {"sin_q2": 0.08, "cos_q2": 0.007, "sin_q23": -0.01, "cos_q23": 0.056},
                                     "J3": {"sin_q23": 0.02, "cos_q23": 0.052}}}
    return data


COMPLIANCE_FIELDS = [("compliance",) + p for p in robot_paths(_with_compliance()["compliance"])]


@FUZZ
@given(where=st.sampled_from(COMPLIANCE_FIELDS), value=JUNK)
def test_malformed_compliance_sections_for_evaluate(files, tmp_path_factory, where, value):
    work = tmp_path_factory.mktemp("compliance")
    robot = work / "robot.json"
    robot.write_text(json.dumps(mutate(_with_compliance(), where, value), allow_nan=True))
    code, err = run(["evaluate", "--robot", str(robot), "--measurements", str(files / "m.csv"), "--register-base"],
                    work)
    if code != 0:
        assert_one_clear_line(code, err, [str(robot)])
