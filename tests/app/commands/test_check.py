"""`robocal check` on the virtual lab (ideal measurements): within limits, a tool change found,
diagnosed and re-identified, the log appended, bad input refused."""
from __future__ import annotations

import pytest

from app.cli import main
from app.lab import ideal_lab_measurements
from core.identification.file import write_calibrated_model
from core.identification.solver import identify
from core.monitoring.log import read_check_log
from core.robot.file import read_robot
from tests.app.commands.cli_output import run_json


@pytest.fixture(scope="module")
def calibrated(tmp_path_factory, built_lab):
    folder = tmp_path_factory.mktemp("check")
    lab = built_lab(None, 0, 0.5)
    write_calibrated_model(identify(lab.nominal_robot, ideal_lab_measurements(lab, 50, sigma_mm=0.05, seed=4)),
                           folder / "calibrated.json")
    return folder / "calibrated.json"


def test_no_change_is_within_limits(calibrated, tmp_path, capsys):
    code, data, err = run_json(capsys, ["check", "--robot", str(calibrated), "--log", str(tmp_path / "c.csv"), "--lab"])
    assert code == 0, err
    assert data["check"]["within"] and "diagnosis" not in data
    assert len(read_check_log(tmp_path / "c.csv").checks[0].points) == 8


def test_tool_change_found_diagnosed_and_reidentified(calibrated, tmp_path, capsys):
    log, out = tmp_path / "c.csv", tmp_path / "updated.json"
    code, data, err = run_json(capsys, ["check", "--robot", str(calibrated), "--log", str(log),
                                        "--change", "tool:1.5", "--out", str(out)])
    assert code == 3, err
    assert data["diagnosis"]["kind"] == "tool" and data["diagnosis"]["text"].startswith("The marker moved 1.5 mm")
    assert data["after"]["within"] and data["after"]["rms_mm"] < 0.1 * data["check"]["rms_mm"]
    history = read_robot(out).calibration["history"]
    assert history[-1]["updated"] == "calibrated.json" and history[-1]["changed"] == ["marker.x", "marker.y",
                                                                                     "marker.z"]
    checks = read_check_log(log).checks
    assert sum(len(c.points) for c in checks) == 16          # the check and the check after updating
    code, data, err = run_json(capsys, ["check", "--robot", str(out), "--log", str(log), "--change", "tool:1.5"])
    assert code == 0 and data["check"]["within"], err


def test_bent_link_writes_nothing(calibrated, tmp_path, capsys):
    out = tmp_path / "updated.json"
    code = main(["check", "--robot", str(calibrated), "--log", str(tmp_path / "c.csv"), "--change", "link3:1",
                 "--out", str(out)])
    text = capsys.readouterr().out
    assert code == 3 and "full calibration" in text and not out.exists()


@pytest.mark.parametrize("extra, message", [(["--change", "bend:1"], "cannot read the change"),
                                            (["--alpha", "0.9"], "false-alarm"),
                                            (["--stereo", "s.yaml"], "--stereo and --marker")])
def test_usage_errors(calibrated, tmp_path, capsys, extra, message):
    code = main(["check", "--robot", str(calibrated), "--log", str(tmp_path / "c.csv"), "--lab"] + extra)
    assert code == 2 and message in capsys.readouterr().err


def test_uncalibrated_robot_is_one_line(tmp_path, capsys):
    from core.robot.model import robot_path
    code = main(["check", "--robot", str(robot_path("educational_6r")), "--log", str(tmp_path / "c.csv"), "--lab"])
    err = capsys.readouterr().err
    assert code == 1 and "holds no calibration" in err and len(err.strip().splitlines()) == 1


def test_log_cannot_be_the_robot(calibrated, capsys):
    assert main(["check", "--robot", str(calibrated), "--log", str(calibrated)]) == 2
