"""`robocal simulate` on the command line: output, --json, exit codes and one-line errors."""
from __future__ import annotations

import json

from app.cli import main


def test_simulate_json(tmp_path, capsys):
    out = tmp_path / "ds"
    code = main(["simulate", "--out", str(out), "--pairs", "1", "--poses", "1", "--seed", "3", "--json"])
    captured = capsys.readouterr()
    assert code == 0, captured.err
    data = json.loads(captured.out)
    assert data["checkerboard_pairs"] == 1 and data["poses"] == 1 and data["seed"] == 3
    assert data["out"] == str(out)
    for key in ("truth", "joints", "training_image"):
        assert (tmp_path / data[key]).is_file()
    assert (out / "checkerboard" / "left" / "pair_000.png").is_file()
    assert (out / "poses" / "right" / "pose_000.png").is_file()
    assert captured.err == ""          # progress only goes to a terminal


def test_simulate_text_and_robot_option(tmp_path, capsys):
    from core.robot.model import robot_path
    out = tmp_path / "ur5"
    code = main(["simulate", "--out", str(out), "--pairs", "0", "--poses", "1", "--robot", str(robot_path("ur5"))])
    captured = capsys.readouterr()
    assert code == 0, captured.err
    assert "UR5" in captured.out and str(out) in captured.out
    truth = json.loads((out / "truth.json").read_text())
    assert truth["nominal_robot"]["name"] == "Universal Robots UR5"


def test_non_writable_output_folder(tmp_path, capsys):
    blocker = tmp_path / "a-file"
    blocker.write_text("not a folder")
    out = blocker / "ds"
    code = main(["simulate", "--out", str(out), "--pairs", "1", "--poses", "1"])
    captured = capsys.readouterr()
    assert code == 1
    lines = captured.err.strip().splitlines()
    assert len(lines) == 1 and str(out) in lines[0]
    assert "Traceback" not in captured.err and captured.out == ""


def test_malformed_robot_file(tmp_path, capsys):
    bad = tmp_path / "robot.json"
    bad.write_text(json.dumps({"format": "robocal.robot/1", "joints": [
        {"type": "revolute", "theta": "ten", "d": 0, "a": 0, "alpha": 0, "min": -90, "max": 90}]}))
    out = tmp_path / "ds"
    code = main(["simulate", "--out", str(out), "--robot", str(bad)])
    captured = capsys.readouterr()
    assert code == 1
    lines = captured.err.strip().splitlines()
    assert len(lines) == 1 and str(bad) in lines[0] and "joints[0].theta" in lines[0]
    assert not out.exists()


def test_unknown_robot_format_and_missing_file(tmp_path, capsys):
    bad = tmp_path / "robot.json"
    bad.write_text(json.dumps({"format": "robocal.robot/9", "joints": []}))
    assert main(["simulate", "--out", str(tmp_path / "ds"), "--robot", str(bad)]) == 1
    assert "version" in capsys.readouterr().err
    assert main(["simulate", "--out", str(tmp_path / "ds"), "--robot", str(tmp_path / "none.json")]) == 1
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and "none.json" in err


def test_usage_errors(tmp_path, capsys):
    assert main(["simulate", "--pairs", "2"]) == 2                 # --out is required
    capsys.readouterr()
    assert main(["simulate", "--out", str(tmp_path / "x"), "--poses", "-3"]) == 2
    assert len(capsys.readouterr().err.strip().splitlines()) == 1
    assert main(["simulate", "--out", str(tmp_path / "x"), "--noise", "loud"]) == 2
    assert not (tmp_path / "x").exists()


def test_poses_file_renders_the_given_poses(tmp_path, capsys, monkeypatch):
    """A selected pose sequence rendered instead of random poses; the robot named as a preset."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "sel.csv").write_text("pose,q1,q2,q3,q4,q5,q6\n0,10,-20,-100,30,-60,15\n1,-30,-40,-90,60,-70,-45\n")
    code = main(["simulate", "--out", "sel", "--pairs", "0", "--poses-file", "sel.csv", "--robot", "educational_6r",
                 "--seed", "2", "--json"])
    captured = capsys.readouterr()
    assert code == 0, captured.err
    assert json.loads(captured.out)["poses"] == 2
    rows = (tmp_path / "sel" / "poses" / "joints.csv").read_text().splitlines()
    assert rows[1].split(",")[1:] == ["10.000", "-20.000", "-100.000", "30.000", "-60.000", "15.000"]
    assert (tmp_path / "sel" / "poses" / "left" / "pose_001.png").is_file()
    (tmp_path / "bad.csv").write_text("pose,q1,q2\n0,1,2\n")
    assert main(["simulate", "--out", "bad", "--pairs", "0", "--poses-file", "bad.csv"]) == 1
    assert "bad.csv" in capsys.readouterr().err and not (tmp_path / "bad").exists()
