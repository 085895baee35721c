"""`robocal reidentify` refusing what it cannot use: no check in the log, the new poses given twice
or not at all (one line each, nothing written). The re-identification of a tool change found by a
check: tests/app/commands/test_check_files.py."""
from __future__ import annotations

import pytest

from app.cli import main
from core.measurement.file import write_measurements
from core.robot.file import read_robot
from core.robot.model import robot_path
from core.virtual_lab.synthetic import perturbed_model, simulate_measurements

ROBOT = str(robot_path("educational_6r"))


@pytest.fixture(scope="module")
def calibrated(tmp_path_factory):
    """(measurements of a perturbed arm at 30 poses, the model identified from them)."""
    folder = tmp_path_factory.mktemp("reidentify")
    write_measurements(simulate_measurements(perturbed_model(read_robot(ROBOT), 4), 30, rng=5), folder / "m.csv")
    assert main(["identify", "--robot", ROBOT, "--measurements", str(folder / "m.csv"),
                 "--out", str(folder / "cal.json")]) == 0
    return folder / "m.csv", folder / "cal.json"


def test_reidentify_without_a_check_is_one_line(calibrated, tmp_path, capsys):
    measurements, robot = calibrated
    capsys.readouterr()
    (tmp_path / "c.csv").write_text("")
    code = main(["reidentify", "--robot", str(robot), "--log", str(tmp_path / "c.csv"), "--change", "tool",
                 "--measurements", str(measurements), "--out", str(tmp_path / "u.json")])
    err = capsys.readouterr().err
    assert code == 1 and "check log" in err and len(err.strip().splitlines()) == 1
    assert not (tmp_path / "u.json").exists()


@pytest.mark.parametrize("new_poses, says", [
    ([], "give the new poses"),
    (["--measurements", "{m}", "--joints", "j.csv"], "one or the other")])
def test_the_new_poses_given_twice_or_not_at_all_are_a_usage_error(calibrated, tmp_path, capsys, new_poses, says):
    measurements, robot = calibrated
    capsys.readouterr()
    code = main(["reidentify", "--robot", str(robot), "--log", str(tmp_path / "c.csv"), "--change", "tool",
                 "--out", str(tmp_path / "u.json")] + [a.format(m=measurements) for a in new_poses])
    err = capsys.readouterr().err
    assert code == 2 and says in err and len(err.strip().splitlines()) == 1, err
    assert list(tmp_path.iterdir()) == []
