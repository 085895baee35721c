"""`robocal grade`: a mark sheet against the lab's true robot, the answer key, bad input."""
from __future__ import annotations

import json

import pytest

from app.cli import main
from core.identification.file import write_calibrated_model
from core.identification.solver import identify
from core.virtual_lab.ideal_measurements import ideal_lab_measurements
from core.virtual_lab.lab import VirtualLab


@pytest.fixture(scope="module")
def calibrated(tmp_path_factory):
    lab = VirtualLab.create(seed=4)
    result = identify(lab.nominal_robot, ideal_lab_measurements(lab, 40, sigma_mm=0.05, seed=2))
    return write_calibrated_model(result, tmp_path_factory.mktemp("grade") / "calibrated.json")


def test_mark_sheet_and_answer_key(calibrated, tmp_path, capsys):
    key = tmp_path / "key.json"
    assert main(["grade", str(calibrated), "--lab-seed", "4", "--fresh", "20", "--answer-key", str(key), "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["marks"] == data["out_of"] == len(data["parameters"]) + 1 and data["fresh_poses"]["count"] == 20
    reasons = {r["name"]: r["reason"] for r in data["not_compared"]}
    assert "base pose absorbs it" in reasons["J1.theta"] and "last joint's axis" in reasons["J6.a"]
    answer = json.loads(key.read_text())
    assert answer["format"] == "robocal.answer-key/1" and answer["lab_seed"] == 4 and len(answer["fresh_poses"]) == 20
    rows = {r["name"]: r for r in answer["parameters"]}
    assert "not_compared" in rows["J1.d"] and "not_compared" not in rows["J3.a"]
    assert rows["J3.a"]["true"] == pytest.approx(rows["J3.a"]["nominal"] + rows["J3.a"]["error"])
    # the text names what it cannot compare; another seed's robot is another robot
    assert main(["grade", str(calibrated), "--lab-seed", "5", "--fresh", "20"]) == 0
    text = capsys.readouterr().out
    assert "Mark sheet:" in text and "J6.theta: not compared" in text and "OFF" in text


def test_bad_input(calibrated, tmp_path, capsys):
    assert main(["grade", "--lab-seed", "4"]) == 2
    assert "--answer-key" in capsys.readouterr().err
    assert main(["grade", str(tmp_path / "none.json"), "--lab-seed", "4"]) == 1
    assert "none.json" in capsys.readouterr().err
    assert main(["grade", str(calibrated), "--lab-seed", "4", "--stereo", str(tmp_path / "s.yaml")]) == 1
    assert "s.yaml" in capsys.readouterr().err
