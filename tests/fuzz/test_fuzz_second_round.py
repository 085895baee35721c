"""Fuzzing the commands added after the first round: robot-import (URDF files and link names),
import-measurements (CSV files of other tools), stereo-import of OpenVINS / Kalibr IMU chains,
identify-tool (calibrated robot files), check (check logs of another kind), and report (project
files); compensate's and reidentify's inputs in the property below (their files are fuzzed in
tests/fuzz/test_fuzz_compensation.py and tests/fuzz/test_fuzz_reidentify.py).

The rule of tests/fuzz/test_fuzz_commands.py: exit 1 (bad data) or 2 (usage), exactly one line
on stderr naming the file or the option, no traceback or "internal error", and no file created
or changed (every input is hashed before and after: `run` compares the work folder's bytes) —
or, where the mutation leaves a valid input, success. Derandomised hypothesis, few examples per
command so that the file runs in seconds.
"""
from __future__ import annotations

import hashlib
import json
import re
from pathlib import Path

import cv2
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from tests.fuzz.cells import with_cell
from tests.fuzz.test_fuzz_commands import JUNK, ROBOT, assert_one_clear_line, mutate, robot_paths, run
from tests.fuzz.test_fuzz_reidentify import cell  # noqa: F401  (the fixture: a check log to re-identify from)

FAST = settings(derandomize=True, max_examples=40, deadline=None, database=None,
                suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
FEW = settings(FAST, max_examples=8)                        # commands that run the virtual lab when the input holds
FEWEST = settings(FAST, max_examples=4)
URDF = Path(__file__).resolve().parents[1] / "data" / "robots" / "fanuc_lrmate200id.urdf"
URDF_JUNK = ["", "nan", "inf", "1e308", "-1e308", "x", "0 0", "1 2 3 4", "0 0 0", "9" * 400, "1e3 0 0",
             "${pi/2}", "&amp;", "-0", "1e-300"]


def digests(folder: Path) -> dict:
    return {p.relative_to(folder): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(folder.rglob("*")) if p.is_file()}


# -- robot-import --------------------------------------------------------------------------------

URDF_ATTRIBUTES = [(m.start(1), m.end(1)) for m in re.finditer(r'(?:xyz|rpy|lower|upper|type|link|name)="([^"]*)"',
                                                               URDF.read_text())]


@FAST
@given(where=st.sampled_from(URDF_ATTRIBUTES), value=st.sampled_from(URDF_JUNK),
       tip=st.sampled_from([None, "tool0", "base_link", "link_3", "nowhere", "../x"]))
def test_malformed_urdf_files(tmp_path_factory, where, value, tip):
    work = tmp_path_factory.mktemp("urdf")
    text = URDF.read_text()
    urdf = work / "robot.urdf"
    urdf.write_text(text[:where[0]] + value + text[where[1]:])
    argv = ["robot-import", str(urdf), "--out", str(work / "robot.json")] + (["--tip", tip] if tip else [])
    code, err = run(argv, work)
    if code != 0:
        assert_one_clear_line(code, err, [str(urdf), "--tip"])
        assert not (work / "robot.json").exists()


@FAST
@given(cut=st.integers(0, 4000), action=st.sampled_from(["truncate", "drop line", "mm", "xacro", "mimic"]))
def test_cut_and_rewritten_urdf_files(tmp_path_factory, cut, action):
    work = tmp_path_factory.mktemp("urdf_cut")
    text = URDF.read_text()
    lines = text.splitlines()
    if action == "truncate":
        text = text[:cut % len(text)]
    elif action == "drop line":
        del lines[cut % len(lines)]
        text = "\n".join(lines)
    elif action == "mm":                                     # every length × 1000: millimetres in a metre format
        text = re.sub(r'xyz="([^"]*)"', lambda m: 'xyz="' + " ".join(f"{1000 * float(v):g}" for v in m.group(1).split())
                      + '"', text)
    elif action == "xacro":
        text = text.replace("<robot ", '<robot xmlns:xacro="http://www.ros.org/wiki/xacro" ', 1).replace(
            'lower="', 'lower="${-', 1)
    else:
        joints = [m.start() for m in re.finditer(r"</joint>", text)]
        at = joints[cut % len(joints)]
        text = text[:at] + '<mimic joint="joint_1"/>' + text[at:]
    urdf = work / "robot.urdf"
    urdf.write_text(text)
    code, err = run(["robot-import", str(urdf), "--out", str(work / "robot.json")], work)
    if action in ("mm", "xacro", "mimic"):
        assert_one_clear_line(code, err, [str(urdf)])
    elif code != 0:
        assert_one_clear_line(code, err, [str(urdf)])


# -- import-measurements -------------------------------------------------------------------------

@pytest.fixture(scope="module")
def tracker_csv(tmp_path_factory):
    """A laser tracker's CSV: pose id, joints in degrees, positions in mm, semicolons."""
    from core.measurement.file import read_measurements

    folder = tmp_path_factory.mktemp("tracker")
    meas = read_measurements(_valid_measurements(folder))
    rows = ["Pose ID;J1;J2;J3;J4;J5;J6;X;Y;Z"]
    for i in range(meas.n_points):
        rows.append(";".join([str(meas.pose[i])] + [f"{v:.4f}" for v in meas.q_file[i]]
                             + [f"{v:.4f}" for v in meas.xyz[i]]))
    return "\n".join(rows) + "\n"


def _valid_measurements(folder: Path) -> Path:
    from core.measurement.file import write_measurements
    from core.robot.file import read_robot
    from core.virtual_lab.synthetic import perturbed_model, simulate_measurements

    path = folder / "m.csv"
    write_measurements(simulate_measurements(perturbed_model(read_robot(ROBOT), 4), 12, rng=5), path)
    return path


@FAST
@given(line=st.integers(0, 13), column=st.integers(0, 9),
       value=st.one_of(st.text(alphabet=" ;,\"#x0123456789.e-+n\r\x00", max_size=8),
                       st.sampled_from(["nan", "inf", "1e308", "", "9" * 400, "X_m", "q1_rad", "Pose ID", "0.4"])),
       units=st.sampled_from([[], ["--length-unit", "m"], ["--angle-unit", "rad"], ["--robot", str(ROBOT)]]))
def test_malformed_tracker_files(tracker_csv, tmp_path_factory, line, column, value, units):
    work = tmp_path_factory.mktemp("import")
    csv = work / "tracker.csv"
    csv.write_text(with_cell(tracker_csv, line, column, value, sep=";"))
    code, err = run(["import-measurements", str(csv), "--out", str(work / "m.csv"), *units], work)
    if code != 0:
        assert_one_clear_line(code, err, [str(csv), "--"])
        assert not (work / "m.csv").exists()


def test_positions_in_metres_are_refused_with_the_unit_to_give(tracker_csv, tmp_path):
    lines = tracker_csv.splitlines()
    metres = [lines[0]] + [";".join(c[:7] + [f"{float(v) / 1000:.7f}" for v in c[7:]])
                           for c in (ln.split(";") for ln in lines[1:])]
    csv = tmp_path / "tracker.csv"
    csv.write_text("\n".join(metres) + "\n")
    code, err = run(["import-measurements", str(csv), "--out", str(tmp_path / "m.csv")], tmp_path)
    assert_one_clear_line(code, err, [str(csv)])
    assert "look like metres" in err[0] and "--length-unit m" in err[0]
    code, err = run(["import-measurements", str(csv), "--length-unit", "m", "--out", str(tmp_path / "m.csv")], tmp_path)
    assert code == 0, err


# -- stereo-import: chains through an IMU --------------------------------------------------------

@pytest.fixture(scope="module")
def imu_chain(tmp_path_factory):
    from core.virtual_lab.rig import default_rig
    from tests.core.stereo.test_importers import _imu_chain

    return _imu_chain(default_rig(0), tmp_path_factory.mktemp("imu") / "chain.yaml", "T_imu_cam",
                      "%YAML:1.0\n").read_text()


@FAST
@given(line=st.integers(0, 60), value=st.sampled_from(["nan", "1e308", "", "x", "[", "- [1, 0]", "equidistant",
                                                        "fisheye", "0", "T_cn_cnm1:", "%YAML:1.0", "\ufeff"]))
def test_malformed_imu_camera_chains(imu_chain, tmp_path_factory, line, value):
    work = tmp_path_factory.mktemp("chain")
    lines = imu_chain.splitlines()
    i = min(line, len(lines) - 1)
    head, _, tail = lines[i].partition(":")
    lines[i] = f"{head}: {value}" if tail.strip() else lines[i].replace(lines[i].strip(), value, 1)
    chain = work / "chain.yaml"
    chain.write_text("\n".join(lines) + "\n")
    code, err = run(["stereo-import", str(chain), "--out", str(work / "stereo.yaml")], work)
    if code != 0:
        assert_one_clear_line(code, err, [str(chain)])


# -- identify-tool and check: calibrated robot files, check logs ---------------------------------

@pytest.fixture(scope="module")
def tool_cell(tmp_path_factory):
    """The two-tool virtual cell (tests/core/tools/two_tools.py), calibrated with its gripper."""
    from core.identification.file import write_calibrated_model
    from core.identification.solver import identify
    from core.robot.file import read_robot, write_robot
    from app.lab import build_lab, ideal_lab_measurements
    from tests.core.tools.two_tools import two_tool_robot

    folder = tmp_path_factory.mktemp("tool_cell")
    robot = write_robot(two_tool_robot(), folder / "robot.json")
    lab = build_lab(read_robot(robot), 0, 0.5)
    write_calibrated_model(identify(lab.nominal_robot, ideal_lab_measurements(lab, 50, sigma_mm=0.05, seed=4)),
                           folder / "calibrated.json")
    return json.loads((folder / "calibrated.json").read_text()), robot.read_text()


def _tool_fields(cal: dict) -> list[tuple]:
    return ([("tools",) + p for p in robot_paths(cal["tools"])] + [("tools",), ("targets",)]
            + [("calibration",) + p for p in robot_paths(cal["calibration"]) if len(p) <= 2])


@FEW
@given(data=st.data(), value=JUNK)
def test_malformed_calibrated_files_for_identify_tool(tool_cell, tmp_path_factory, data, value):
    cal, robot = tool_cell
    where = data.draw(st.sampled_from(_tool_fields(cal)))
    work = tmp_path_factory.mktemp("tool")
    (work / "robot.json").write_text(robot)
    path = work / "calibrated.json"
    path.write_text(json.dumps(mutate(json.loads(json.dumps(cal)), where, value), allow_nan=True))
    code, err = run(["identify-tool", "--robot", str(path), "--tool", "long_gripper", "--lab-robot",
                     str(work / "robot.json"), "--poses-out", str(work / "poses.csv")], work)
    if code != 0:
        assert_one_clear_line(code, err, [str(path), str(work / "robot.json"), "--tool"])
        assert not (work / "poses.csv").exists()


def _png() -> bytes:
    ok, buf = cv2.imencode(".png", np.full((4, 4), 200, np.uint8))
    return buf.tobytes()


CHECK_LOGS = {"png": _png(), "folder": None}      # each a full check on the lab first: two cases
                                                 # (tests/core/test_refused_files.py has the rest, on the writer)


@pytest.mark.parametrize("kind", CHECK_LOGS)
def test_check_logs_of_another_kind_are_refused_unchanged(tool_cell, tmp_path, kind):
    """`check --log` onto a PNG (it lost 15 bytes once) or a folder: refused with the log named,
    every byte kept."""
    cal, robot = tool_cell
    (tmp_path / "robot.json").write_text(robot)
    path = tmp_path / "calibrated.json"
    path.write_text(json.dumps(cal))
    log = tmp_path / "checks.csv"
    if CHECK_LOGS[kind] is None:
        log.mkdir()
    else:
        log.write_bytes(CHECK_LOGS[kind])
    code, err = run(["check", "--robot", str(path), "--log", str(log), "--lab-robot", str(tmp_path / "robot.json"),
                     "--count", "5"], tmp_path)
    assert_one_clear_line(code, err, [str(log)])
    assert "repair" not in err[0] and ("this is a folder" in err[0] if kind == "folder" else True), err[0]


# -- report: project files -----------------------------------------------------------------------

PROJECT_FILES = ["project.json", "stereo.yaml", "measurements.csv", "calibrated.json", "poses.csv"]
BAD_BYTES = [b"", _png(), b"{", b"\x00" * 16, b"not: [an, opencv, file\n", b"# robocal.measurements/1\npose\n",
             json.dumps({"format": "robocal.project/9"}).encode()]


@FEW
@given(name=st.sampled_from(PROJECT_FILES), content=st.sampled_from(BAD_BYTES))
def test_report_of_a_project_with_damaged_files(qapp, tmp_path_factory, name, content):
    from core.project import create_project

    work = tmp_path_factory.mktemp("report")
    folder = create_project(work / "project").folder
    (folder / name).write_bytes(content)
    before = digests(folder)
    out = work / "report.html"
    code, err = run(["report", str(folder), "--out", str(out), "--no-truth"], work)
    assert digests(folder) == before
    if code != 0:
        assert_one_clear_line(code, err, [str(folder)])
        assert not out.exists()
    else:
        assert out.read_bytes().startswith(b"<!DOCTYPE html") or b"<html" in out.read_bytes()[:400]


# -- the property: a refused command changes no input --------------------------------------------

JUNK_FILES = {"empty": b"", "png": _png(), "binary": bytes(range(256)), "text": b"hello\nworld",
              "cut json": b'{"format": "robocal.robot/1", "joints": [', "bom": b"\xef\xbb\xbf{}",
              "no newline csv": b"pose,q1,x\n1,2"}


def _commands(valid: dict) -> dict:
    """argv per command, with {name} where the input of that name goes (all inside the work folder)."""
    return {
        "robot-import": (["robot-import", "{urdf}", "--out", "{out}/r.json"], ["urdf"]),
        "import-measurements": (["import-measurements", "{csv}", "--robot", "{robot}", "--out", "{out}/m.csv"],
                                ["csv", "robot"]),
        "stereo-import": (["stereo-import", "{stereo}", "--out", "{out}/s.yaml"], ["stereo"]),
        "identify": (["identify", "--robot", "{robot}", "--measurements", "{meas}", "--out", "{out}/c.json"],
                     ["robot", "meas"]),
        "identify-tool": (["identify-tool", "--robot", "{robot}", "--tool", "gripper", "--measurements", "{meas}",
                           "--out", "{out}/t.json"], ["robot", "meas"]),
        "locate-fixture": (["locate-fixture", "--stereo", "{stereo}", "--marker", "{marker}", "--calibrated",
                            "{robot}", "--fixture", "{fixture}", "{out}", "--out", "{out}/p.json"],
                           ["stereo", "marker", "robot", "fixture"]),
        "export": (["export", "--robot", "{robot}", "--format", "urdf", "--out", "{out}/r.urdf"], ["robot"]),
        "compensate": (["compensate", "--robot", "{robot}", "--targets", "{targets}", "--frame", "{fixture_pose}",
                        "--position-only", "--out", "{out}/j.csv"], ["robot", "targets", "fixture_pose"]),
        "compensate --program": (["compensate", "--robot", "{robot}", "--program", "{program}", "--nominal",
                                  "{nominal}", "--position-only", "--format", "gcode", "--out", "{out}/p.gcode"],
                                 ["robot", "program", "nominal"]),
        "reidentify": (["reidentify", "--robot", "{calibrated}", "--log", "{log}", "--change", "base", "--measurements",
                        "{new}", "--out", "{out}/u.json"], ["calibrated", "log", "new"]),
    }


@pytest.fixture(scope="module")
def valid_inputs(files, tracker_csv, cell, tmp_path_factory):
    from tests.core.stereo import foreign_files as ff
    from tests.fuzz.test_fuzz_compensation import FIXTURE_POSE, FIXTURE_TARGETS, PROGRAM
    from core.virtual_lab.rig import default_rig

    folder = tmp_path_factory.mktemp("valid")
    return {"urdf": URDF.read_bytes(), "csv": tracker_csv.encode(), "robot": Path(ROBOT).read_bytes(),
            "meas": (files / "m.csv").read_bytes(),
            "stereo": ff.opencv_file(default_rig(0), folder / "stereo.yml").read_bytes(),
            "marker": _png(), "fixture": json.dumps({"format": "robocal.fixture-description/1", "points": [
                {"name": n} for n in "ABC"]}).encode(),
            "targets": FIXTURE_TARGETS.encode(), "fixture_pose": json.dumps(FIXTURE_POSE).encode(),
            "program": PROGRAM.encode(), "nominal": Path(ROBOT).read_bytes(),
            "calibrated": cell["calibrated"].encode(), "log": cell["log"].encode(), "new": cell["new"].encode()}


SUFFIX = {"urdf": ".urdf", "csv": ".csv", "robot": ".json", "meas": ".csv", "stereo": ".yml", "marker": ".png",
          "fixture": ".json", "targets": ".csv", "fixture_pose": ".json", "program": ".csv", "nominal": ".json",
          "calibrated": ".json", "log": ".csv", "new": ".csv"}


@FAST
@given(command=st.sampled_from(sorted(_commands({}))), junk=st.sampled_from(sorted(JUNK_FILES)), which=st.integers(0, 3))
def test_no_refused_command_changes_an_input(valid_inputs, tmp_path_factory, command, junk, which):
    """One input of a command replaced by junk (the others valid): when the command refuses, the
    sha256 of every file in the work folder (all its inputs) is the same before and after, and no
    output appeared."""
    _refusal_keeps_every_input(valid_inputs, tmp_path_factory.mktemp("inputs"), command, junk, which)


EVERY_INPUT = [(command, which, junk) for command in ("compensate", "compensate --program", "reidentify")
               for which in range(3) for junk in sorted(JUNK_FILES)]


@pytest.mark.parametrize("command, which, junk", EVERY_INPUT)
def test_refused_compensate_or_reidentify_changes_no_input(valid_inputs, tmp_path, command, which, junk):
    """The same property for every input of `compensate` (robot, targets, fixture pose; robot,
    program, nominal) and of `reidentify` (calibrated robot, check log, new measurements) and
    every kind of junk: always refused, nothing changed or written."""
    code = _refusal_keeps_every_input(valid_inputs, tmp_path, command, junk, which)
    assert code != 0


@pytest.mark.parametrize("command", ["compensate", "compensate --program", "reidentify"])
def test_compensate_and_reidentify_with_the_valid_inputs_write_their_output(valid_inputs, tmp_path, command):
    """The inputs the property damages one by one are valid together: the refusals come from the junk."""
    argv, names = _commands(valid_inputs)[command]
    paths = {name: tmp_path / f"{name}{SUFFIX[name]}" for name in names}
    for name in names:
        paths[name].write_bytes(valid_inputs[name])
    (tmp_path / "out").mkdir()
    code, err = run([a.format(out=tmp_path / "out", **paths) for a in argv], tmp_path)
    assert code == 0, err
    assert len(list((tmp_path / "out").iterdir())) == 1


def _refusal_keeps_every_input(valid_inputs, work: Path, command: str, junk: str, which: int) -> int:
    argv, names = _commands(valid_inputs)[command]
    bad = names[which % len(names)]
    paths = {}
    for name in names:
        paths[name] = work / f"{name}{SUFFIX[name]}"
        paths[name].write_bytes(JUNK_FILES[junk] if name == bad else valid_inputs[name])
    (work / "out").mkdir()
    before = digests(work)
    code, err = run([a.format(out=work / "out", **paths) for a in argv], work)
    if code != 0:
        assert digests(work) == before
        assert_one_clear_line(code, err, [str(paths[bad]), str(work)])
    return code
