"""Fuzzing what `robocal reidentify` reads: the check log (its last check's points), the new
poses' measurement file, the calibrated robot file and the --change value.

The rule of tests/fuzz/test_fuzz_commands.py: a refusal is exit 1 (bad data) or 2 (usage) with
exactly one stderr line naming the file or the option, no traceback or "internal error", no
file created or changed (the log included); otherwise the command ran: exit 0 with the updated
robot written, or 3 (the updated robot still out of limits: nothing written, its check appended
to the log). Derandomised hypothesis, few examples: a run that goes through takes seconds.

The cell: the fuzz calibration (tests/fuzz/test_fuzz_files.py) checked on 8 of its own
measurements with the robot base moved 2 mm (the check names the base), and 3 more measured
after the move as the new poses.
"""
from __future__ import annotations

import contextlib
import io
import json
from pathlib import Path

import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from app.cli import main
from tests.fuzz.test_fuzz_commands import JUNK, assert_one_clear_line, mutate, robot_paths, snapshot
from tests.fuzz.test_fuzz_files import calibrated

FEW = settings(derandomize=True, max_examples=8, deadline=None, database=None,
               suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
MORE = settings(FEW, max_examples=20)                   # inputs refused before anything is computed
OUT_OF_LIMITS = 3
CELL_JUNK = st.one_of(st.text(alphabet=' ,"#x0123456789.e-+n\r\x00', max_size=8),
                      st.sampled_from(["nan", "inf", "1e308", "", "9" * 400, "-1", "overall", "point", "pose"]))


def _moved_base(measurements: str, rows: slice) -> str:
    """The measurement file's header and `rows` of its points, x moved by 2 mm (the base moved)."""
    lines = measurements.splitlines()
    head = [ln for ln in lines if not ln[:1].isdigit()]
    points = [ln.split(",") for ln in lines if ln[:1].isdigit()][rows]
    for cells in points:
        cells[8] = f"{float(cells[8]) + 2.0:.6f}"
    return "\n".join(head + [",".join(c) for c in points]) + "\n"


@pytest.fixture(scope="module")
def cell(files, tmp_path_factory) -> dict:
    """The texts of the calibrated robot, the check log and the new measurements."""
    folder = tmp_path_factory.mktemp("reid_cell")
    (folder / "calibrated.json").write_text(json.dumps(calibrated(files)))
    measurements = (files / "m.csv").read_text()
    (folder / "check.csv").write_text(_moved_base(measurements, slice(0, 8)))
    (folder / "new.csv").write_text(_moved_base(measurements, slice(8, 11)))
    code = main(["check", "--robot", str(folder / "calibrated.json"), "--log", str(folder / "checks.csv"),
                 "--measurements", str(folder / "check.csv")])
    assert code == OUT_OF_LIMITS
    return {name: (folder / f).read_text() for name, f in (("calibrated", "calibrated.json"), ("log", "checks.csv"),
                                                           ("new", "new.csv"))}


def reidentify(work: Path, cell: dict, *, change: str = "base", **replaced) -> tuple[int, list[str], dict]:
    """`robocal reidentify` in `work` on the cell's files, some replaced by the texts given:
    exit code, stderr lines and the paths."""
    paths = {"calibrated": work / "calibrated.json", "log": work / "checks.csv", "new": work / "new.csv"}
    for name, path in paths.items():
        path.write_text(replaced.get(name, cell[name]))
    out = work / "updated.json"
    before = snapshot(work)
    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        code = main(["reidentify", "--robot", str(paths["calibrated"]), "--log", str(paths["log"]), "--change", change,
                     "--measurements", str(paths["new"]), "--out", str(out)])
    lines = err.getvalue().strip().splitlines()
    if code in (1, 2):
        assert snapshot(work) == before, "files changed by a refused run"
    else:
        assert code in (0, OUT_OF_LIMITS), (code, lines)
        assert out.exists() == (code == 0)
    return code, lines, paths


def test_the_valid_files_update_the_base(cell, tmp_path):
    code, lines, paths = reidentify(tmp_path, cell)
    assert code == 0, lines
    assert paths["log"].read_text().startswith(cell["log"])          # the updated robot's check appended


def _with_cell(text: str, line: int, column: int, value: str, sep: str = ",") -> str:
    lines = text.splitlines()
    i = line % len(lines)
    cells = lines[i].split(sep)
    cells[column % len(cells)] = value
    lines[i] = sep.join(cells)
    return "\n".join(lines) + "\n"


@FEW
@given(line=st.integers(0, 40), column=st.integers(0, 20), value=CELL_JUNK)
def test_malformed_check_logs(cell, tmp_path_factory, line, column, value):
    work = tmp_path_factory.mktemp("log")
    code, lines, paths = reidentify(work, cell, log=_with_cell(cell["log"], line, column, value))
    if code in (1, 2):
        assert_one_clear_line(code, lines, [str(paths["log"])])


@settings(FEW, max_examples=5)
@given(cut=st.integers(0, 10_000), how=st.sampled_from(["cut", "no last line", "only the header", "twice"]))
def test_cut_and_repeated_check_logs(cell, tmp_path_factory, cut, how):
    """A log cut anywhere (a check interrupted), without its closing row, or holding the check twice."""
    text = cell["log"]
    lines = text.splitlines(keepends=True)
    log = {"cut": text[:cut % len(text)], "no last line": "".join(lines[:-1]),
           "only the header": "".join(lines[:2]), "twice": text + "".join(lines[2:])}[how]
    work = tmp_path_factory.mktemp("log_cut")
    code, lines_, paths = reidentify(work, cell, log=log)
    if code in (1, 2):
        assert_one_clear_line(code, lines_, [str(paths["log"])])


def _a_number(text: str) -> bool:
    try:
        return abs(float(text)) < 1e5
    except ValueError:
        return False


@MORE
@given(line=st.integers(0, 5), column=st.integers(0, 10), value=CELL_JUNK)
def test_malformed_new_measurements(cell, tmp_path_factory, line, column, value):
    """Malformed cells (a plausible number in place of a coordinate is a wrong measurement, not a
    malformed file: the tests below)."""
    assume(not _a_number(value))
    work = tmp_path_factory.mktemp("new")
    code, lines, paths = reidentify(work, cell, new=_with_cell(cell["new"], line, column, value))
    if code in (1, 2):
        assert_one_clear_line(code, lines, [str(paths["new"])])


@FEW
@given(data=st.data(), value=JUNK)
def test_malformed_calibrated_robot_files(cell, tmp_path_factory, data, value):
    robot = json.loads(cell["calibrated"])
    where = data.draw(st.sampled_from([p for p in robot_paths(robot) if len(p) <= 3]))
    work = tmp_path_factory.mktemp("robot")
    code, lines, paths = reidentify(work, cell, calibrated=json.dumps(mutate(robot, where, value), allow_nan=True))
    if code in (1, 2):
        assert_one_clear_line(code, lines, [str(paths["calibrated"]), str(paths["log"])])


@pytest.mark.parametrize("change", ["", "joint0", "joint7", "JOINT2", "base,tool"])
def test_change_values_that_name_nothing(cell, tmp_path, change):
    code, lines, _ = reidentify(tmp_path, cell, change=change)
    assert_one_clear_line(code, lines, ["--change"])


@pytest.mark.parametrize("line, column", [(2, 2), (2, 4)])
def test_a_wrong_new_point_is_refused_naming_the_new_poses_file(cell, tmp_path, line, column):
    """One new point's q1 (2, 2) or x (2, 4) written as -1: the re-identification cannot fit it.
    Found by the fuzz; today the refusal says 'leaves errors of 495 mm RMS …' naming no file, or
    '<updated.json>: field 'calibration.covariance.parameters': unknown parameter 'J2.beta'' (the
    output, not written, and a parameter of the model's own parametrisation)."""
    code, lines, paths = reidentify(tmp_path, cell, new=_with_cell(cell["new"], line, column, "-1"))
    assert_one_clear_line(code, lines, [str(paths["new"])])
    assert "unknown parameter" not in lines[0]
