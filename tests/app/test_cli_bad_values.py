"""Absurd values in files are one clear line naming the file and field, exit 1, and no output
file: huge finite numbers, out-of-range ids, oversized fields, pathological JSON, truncated marker
files. Absurd option values: tests/app/commands/test_options.py."""
from __future__ import annotations

import json
import shutil

import numpy as np
import pytest

from app.cli import main
from core.measurement.file import write_measurements
from core.robot.file import read_robot
from core.robot.model import robot_path
from core.virtual_lab.synthetic import perturbed_model, simulate_measurements
from tests.app.commands.cli_output import one_line

ROBOT = robot_path("educational_6r")


@pytest.fixture(scope="module")
def good(tmp_path_factory):
    folder = tmp_path_factory.mktemp("good")
    true = perturbed_model(read_robot(ROBOT), 4)
    write_measurements(simulate_measurements(true, 30, rng=5), folder / "m.csv")
    shutil.copy(ROBOT, folder / "robot.json")
    return folder


def with_cell(src, dst, column: str, value: str, row: int = 0):
    """A copy of the measurements file with one cell replaced."""
    lines = src.read_text().splitlines()
    header_at = next(i for i, ln in enumerate(lines) if not ln.startswith("#"))
    cols = lines[header_at].split(",")
    cells = lines[header_at + 1 + row].split(",")
    cells[cols.index(column)] = value
    lines[header_at + 1 + row] = ",".join(cells)
    dst.write_text("\n".join(lines) + "\n")
    return dst


def robot_with(src, dst, edit):
    data = json.loads(src.read_text())
    edit(data)
    dst.write_text(json.dumps(data))
    return dst


@pytest.mark.parametrize("column, value, says", [
    ("x", "1e308", "column 'x'"), ("x", "1e100", "column 'x'"), ("y", "-2e5", "column 'y'"),
    ("q1", "1e300", "column 'q1'"), ("pose", "1e20", "expected a whole number as pose id"),
    ("pose", "9" * 400, "column 'pose'"), ("x", "y" * 200_000, "unreadable row"),
])
def test_absurd_measurements_are_refused_by_identify_and_evaluate(good, tmp_path, capsys, column, value, says):
    m = with_cell(good / "m.csv", tmp_path / "m.csv", column, value)
    out = tmp_path / "cal.json"
    assert main(["identify", "--robot", str(ROBOT), "--measurements", str(m), "--out", str(out)]) == 1
    line = one_line(capsys)
    assert str(m) in line and says in line, line
    assert not out.exists()
    assert main(["evaluate", "--robot", str(ROBOT), "--measurements", str(m), "--register-base"]) == 1
    assert says in one_line(capsys)


@pytest.mark.parametrize("edit, field", [
    (lambda d: d["joints"][0].__setitem__("theta", 1e300), "joints[0].theta"),
    (lambda d: d["joints"][1].__setitem__("a", 1e308), "joints[1].a"),
    (lambda d: d["base"].__setitem__("xyz", [0, 0, 10 ** 400]), "base.xyz[2]"),
])
def test_absurd_robot_values_name_the_field(good, tmp_path, capsys, edit, field):
    robot = robot_with(good / "robot.json", tmp_path / "robot.json", edit)
    out = tmp_path / "cal.json"
    assert main(["identify", "--robot", str(robot), "--measurements", str(good / "m.csv"), "--out", str(out)]) == 1
    line = one_line(capsys)
    assert field in line and str(robot) in line, line
    assert not out.exists()
    assert main(["select-poses", "--robot", str(robot), "--count", "5", "--out", str(tmp_path / "p.csv")]) == 1
    assert field in one_line(capsys)


def test_deeply_nested_json_is_refused(tmp_path, capsys):
    robot = tmp_path / "robot.json"
    robot.write_text("[" * 100_000 + "]" * 100_000)
    assert main(["export", "--robot", str(robot), "--format", "urdf", "--out", str(tmp_path / "r.urdf")]) == 1
    assert "nested too deeply" in one_line(capsys)


def test_truncated_or_misshaped_marker_file(tmp_path, capsys):
    from core.marker.training import TrainedMarker
    from core.errors import RoboCalError
    np.savez(tmp_path / "shape.npz", format=np.array("robocal.marker-trained/1"), keypoints=np.zeros(5))
    good = tmp_path / "good.npz"
    np.savez(good, a=np.arange(1000))
    (tmp_path / "cut.npz").write_bytes(good.read_bytes()[:200])
    for name in ("cut.npz", "shape.npz"):
        with pytest.raises(RoboCalError) as info:
            TrainedMarker.load(tmp_path / name)
        assert name in str(info.value)


def test_a_calibration_sigma_given_as_text_names_the_field(tmp_path, capsys):
    from core.robot.file import write_robot

    cal = read_robot(ROBOT)
    cal.calibration = {"parameters": [{"name": "J1.a", "nominal": 0.0, "identified": 0.1, "std": "about one"}]}
    robot = write_robot(cal, tmp_path / "cal.json")
    out = tmp_path / "dh.csv"
    assert main(["export", "--robot", str(robot), "--format", "dh-csv", "--out", str(out)]) == 1
    line = one_line(capsys)
    assert str(robot) in line and "calibration.parameters[0].std" in line and "'about one'" in line, line
    assert not out.exists()
