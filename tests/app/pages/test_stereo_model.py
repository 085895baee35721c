"""The Stereo step's model without Qt: pairs added, removed, dropped and restored, screened
again with every change, a calibration made stale by a change, and what listeners hear."""
from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import cv2
import numpy as np
import pytest

from app.jobs.stereo import detect_files
from app.pages.stereo.model import StereoModel
from app.pages.stereo.texts import pairs_status
from core.stereo.board import Board
from core.stereo.fit import CalibrationOptions
from tests.app.pages.model_events import heard as listen


@pytest.fixture(scope="module")
def added(built_lab, tmp_path_factory):
    """Four rendered pairs of the lab's board, detected (two AddedPair lists: 3 + 1)."""
    lab = built_lab(seed=0)
    root = tmp_path_factory.mktemp("model")
    paths = []
    for i, pose in enumerate(lab.random_board_poses(4, np.random.default_rng(4))):
        left, right = lab.render_checkerboard_pair(pose, np.random.default_rng([4, i]))
        pair = (root / f"left{i}.png", root / f"right{i}.png")
        for image, path in zip((left, right), pair):
            assert cv2.imwrite(str(path), image)
        paths.append(pair)
    return lab.board, detect_files(paths[:3], lab.board), detect_files(paths[3:], lab.board)


def test_the_model_and_the_adding_jobs_load_no_qt():
    code = ("import sys, app.pages.stereo.model, app.jobs.stereo_pairs; "
            "print(sorted({m.split('.')[0] for m in sys.modules} & {'PySide6', 'pyqtgraph', 'shiboken6', 'widgets'}))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True,
                         cwd=Path(__file__).parents[3])
    assert out.stdout.strip() == "[]"


def test_pairs_added_removed_dropped_and_restored(added):
    board, first, second = added
    model = StereoModel(board)
    assert model.options == CalibrationOptions() and model.result is None
    heard = listen(model, "added", "removed", "pairs")
    model.add(first)
    assert [a.key for a in model.items] == [0, 1, 2] and len(model.usable()) == 3
    assert heard == [("added", first), ("pairs", None)]
    assert model.detections is not None and len(model.detections.pairs) == 3
    model.add(second)
    assert [a.key for a in model.items] == [0, 1, 2, 3] and model.coverage().bars == model.detections.coverage.bars
    heard.clear()
    model.remove([1, 7])
    assert [a.key for a in model.items] == [0, 2, 3] and heard == [("removed", [1]), ("pairs", None)]
    model.exclude([model.items[0].detection])
    assert model.items[0].excluded and [a.key for a in model.usable()] == [2, 3]
    model.restore()
    assert len(model.usable()) == 3
    assert pairs_status(model.items, False) == ("3 pairs on the page.", None)


def test_a_change_makes_the_calibration_stale(added):
    board, first, _ = added
    model = StereoModel(board)
    model.add(first)
    results = listen(model, "result")
    calibration = object()                  # the model keeps whatever the calibration returned
    model.set_result(calibration)
    assert results == [("result", calibration)] and model.current_result() is calibration
    model.remove([model.items[0].key])
    assert model.stale and model.current_result() is None and model.result is calibration
    assert pairs_status(model.items, model.stale)[0].endswith("Pairs changed since the calibration: calibrate again.")
    model.set_result(calibration)
    assert not model.stale


def test_another_project_clears_everything_but_the_options(added, tmp_path):
    board, first, _ = added
    model = StereoModel(board)
    model.add(first)
    model.set_options(CalibrationOptions(radial=6))
    model.set_result(object())
    model.saved_path = tmp_path / "stereo.yaml"
    heard = listen(model, "cleared", "board")
    other = Board(8, 5, 30.0)
    model.reset(other)
    assert heard == [("cleared", None), ("board", other)]
    assert model.items == [] and model.detections is None and model.result is None and not model.stale
    assert model.saved_path is None and model.board == other and model.options.radial == 6
