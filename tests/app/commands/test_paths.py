"""An output that would overwrite one of the command's inputs (the same file, an image inside an
input folder, two outputs naming one file) is a usage error: one line, exit 2, every file as it was."""
from __future__ import annotations

import shutil

import pytest

from app.cli import main
from core.robot.model import robot_path

ROBOT = robot_path("ur5")


@pytest.mark.parametrize("argv, message", [
    (["identify", "--robot", "{robot}", "--measurements", "{m}", "--out", "{m}"],
     "--out is the same file as --measurements"),
    (["export", "--robot", "{robot}", "--format", "urdf", "--out", "{robot}"], "--out is the same file as --robot"),
    (["select-poses", "--robot", "{robot}", "--count", "5", "--out", "{robot}"], "--out is the same file as --robot"),
    (["stereo-calibrate", "--left", "{left}", "--right", "{left}", "--board", "9x6", "--square", "25",
      "--out", "{image}"], "is an image inside the --left folder"),
    (["stereo-calibrate", "--left", "{left}", "--right", "{left}", "--board", "9x6", "--square", "25",
      "--out", "{tmp}/s.yaml", "--export-json", "{tmp}/s.yaml"], "--out and --export-json name the same file"),
])
def test_an_output_that_would_overwrite_an_input_is_a_usage_error(argv, message, tmp_path, capsys):
    robot = tmp_path / "robot.json"
    shutil.copy(ROBOT, robot)
    m = tmp_path / "m.csv"
    m.write_text("# robocal.measurements/1\npose,target,q1,q2,q3,q4,q5,q6,x,y,z\n")
    left = tmp_path / "left"
    left.mkdir()
    (left / "l01.png").write_bytes(b"not really a png")
    values = {"robot": robot, "m": m, "left": left, "image": left / "l01.png", "tmp": tmp_path}
    before = {p: p.read_bytes() for p in tmp_path.rglob("*") if p.is_file()}
    assert main([a.format(**values) for a in argv]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and message in err[0], err
    assert {p: p.read_bytes() for p in tmp_path.rglob("*") if p.is_file()} == before
