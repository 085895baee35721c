"""Inputs shared by the tests of several commands."""
from __future__ import annotations

import json

import pytest


@pytest.fixture(scope="session")
def pose_dataset(tmp_path_factory):
    """(folder, truth): a `robocal simulate` dataset of 6 marker poses (lab seed 3) with a stereo.yaml of
    the true cameras, for `locate` and `measure` (built once per test process; only read)."""
    from core.stereo.board import Board
    from core.camera import CameraModel
    from core.stereo.rectification import StereoRectification
    from core.stereo.file import StereoFile, write_stereo_yaml
    from core.stereo.rig import StereoRig
    from core.virtual_lab.dataset import simulate_dataset

    root = tmp_path_factory.mktemp("marker_cli")
    out = root / "ds"
    simulate_dataset(out, seed=3, pairs=0, poses=6)
    truth = json.loads((out / "truth.json").read_text())
    s = truth["stereo"]
    size = (s["image_width"], s["image_height"])
    rig = StereoRig(CameraModel(s["K1"], s["D1"], *size), CameraModel(s["K2"], s["D2"], *size), s["R"], s["T"])
    rect = StereoRectification.from_rig(rig)
    b = truth["board"]
    write_stereo_yaml(out / "stereo.yaml", StereoFile(
        size, rig.left.K, rig.left.dist, rig.right.K, rig.right.dist, rig.R, rig.T, rig.essential(),
        rig.fundamental(), rect.R1, rect.R2, rect.P1, rect.P2, rect.Q, 0.0, 0.0, 0.0,
        Board(b["cols"], b["rows"], b["square"])))
    return out, truth
