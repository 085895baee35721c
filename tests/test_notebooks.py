"""The worked examples in docs/notebooks/ run and their own checks hold (they never rot)."""
from __future__ import annotations

import contextlib
import io
import runpy
from pathlib import Path

import pytest

NOTEBOOKS = sorted((Path(__file__).resolve().parents[1] / "docs" / "notebooks").glob("*.py"))


def test_there_are_the_three_worked_examples():
    assert {p.stem for p in NOTEBOOKS} == {"least_squares_by_hand", "ssd_window_sweep", "triangulation_sign_slip"}


@pytest.mark.parametrize("script", NOTEBOOKS, ids=lambda p: p.stem)
def test_worked_example_runs(script):
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        runpy.run_path(str(script), run_name="__main__")
    assert len(out.getvalue().splitlines()) >= 3
