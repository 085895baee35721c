"""`robocal robustness`: the marker's detection rate and 3D error under light, occlusion and tilt."""
from __future__ import annotations

import json

import pytest

from app.cli import main


def test_robustness_json_sweeps_only_the_axes_given(capsys):
    code = main(["robustness", "--pairs", "2", "--light", "1,0.05", "--tilt", "30", "--seed", "1", "--json"])
    captured = capsys.readouterr()
    assert code == 0, captured.err
    data = json.loads(captured.out)
    rows = [(r["axis"], r["value"]) for r in data["rows"]]
    assert rows == [("light", 1.0), ("light", 0.05), ("tilt", 30.0)]
    nominal, dark, tilted = data["rows"]
    assert nominal["rendered"] == 2 and nominal["detection_rate"] == 1.0 and nominal["median_error_mm"] < 0.05
    assert dark["detection_rate"] == 0.0 and dark["median_error_mm"] is None and dark["reasons"]
    assert tilted["located"] == 2
    assert data["wrongly_accepted"] == 0 and data["wrong_mm"] == 2.0 and data["units"]["errors"] == "mm"
    assert captured.err == ""


def test_robustness_text_table(capsys):
    code = main(["robustness", "--pairs", "1", "--occlusion", "0,0.7", "--side", "left"])
    captured = capsys.readouterr()
    assert code == 0, captured.err
    lines = captured.out.splitlines()
    assert lines[0].split()[:3] == ["condition", "pairs", "detected"]
    assert lines[1].startswith("occlusion 0 %") and "100%" in lines[1]
    assert lines[2].startswith("occlusion 70 %") and " 0%" in lines[2]
    assert "silent wrong numbers" in lines[-1]


@pytest.mark.parametrize("argv, option", [(["--light", "0"], "--light"), (["--tilt", "30,95"], "--tilt"),
                                          (["--occlusion", "x"], "--occlusion"), (["--pairs", "0"], "--pairs"),
                                          (["--side", "middle"], "--side")])
def test_bad_values_are_one_usage_line(argv, option, capsys):
    code = main(["robustness", *argv])
    captured = capsys.readouterr()
    assert code == 2 and captured.out == ""
    assert option in captured.err and len(captured.err.strip().splitlines()) == 1
