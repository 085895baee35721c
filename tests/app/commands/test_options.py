"""Option values a command cannot use (infinite, negative, out of range, not a number) are a usage
error: one line naming the option, exit 2, nothing written."""
from __future__ import annotations

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
    """A folder with a good measurements file (m.csv) of a perturbed arm at 30 poses."""
    folder = tmp_path_factory.mktemp("good")
    write_measurements(simulate_measurements(perturbed_model(read_robot(ROBOT), 4), 30, rng=5), folder / "m.csv")
    return folder


@pytest.mark.parametrize("argv, option", [
    (["simulate", "--out", "{tmp}/lab", "--noise", "inf"], "--noise"),
    (["simulate", "--out", "{tmp}/lab", "--seed", "-1"], "--seed"),
    (["identify", "--robot", "{robot}", "--measurements", "{m}", "--out", "{tmp}/c.json", "--huber", "inf"], "--huber"),
    (["identify", "--robot", "{robot}", "--measurements", "{m}", "--out", "{tmp}/c.json", "--prior", "-1"], "--prior"),
    (["identify", "--robot", "{robot}", "--measurements", "{m}", "--out", "{tmp}/c.json", "--prior", "often"],
     "--prior"),
    (["select-poses", "--robot", "{robot}", "--count", "5", "--out", "{tmp}/p.csv", "--plate", "-5"], "--plate"),
    (["select-poses", "--robot", "{robot}", "--count", "5", "--out", "{tmp}/p.csv", "--margin", "nan"], "--margin"),
    (["select-poses", "--robot", "{robot}", "--count", "5", "--out", "{tmp}/p.csv", "--lab-seed", "-3"], "--lab-seed"),
    (["select-poses", "--robot", "{robot}", "--count", "5", "--out", "{tmp}/p.csv", "--random-trials", "1000000000"],
     "--random-trials"),
    (["select-poses", "--robot", "{robot}", "--count", "5", "--out", "{tmp}/p.csv", "--candidates", "1000000000"],
     "--candidates"),
])
def test_absurd_options_are_usage_errors(good, tmp_path, capsys, argv, option):
    args = [a.format(tmp=tmp_path, robot=ROBOT, m=good / "m.csv") for a in argv]
    assert main(args) == 2
    assert f"argument {option}:" in one_line(capsys)
    assert list(tmp_path.iterdir()) == []
