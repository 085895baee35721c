"""Inputs the Marker and Measurement page tests share: the virtual lab (built once per test
session, each caller gets its own copy: tests/session_cache.py), a stereo.yaml of its true rig (the calibration itself is tested elsewhere),
and a state with a temporary project that has adopted the lab."""
from __future__ import annotations

import cv2

from core.stereo.file import StereoFile, write_stereo_yaml
from tests.session_cache import lab_copy, trained_marker_copy


def make_lab():
    """A copy of VirtualLab.create(seed=0, noise=0.5): the educational 6R arm."""
    return lab_copy(None, seed=0, noise=0.5)


def lab_marker(lab):
    """The lab's marker trained on its rendered training image, at its true outer size."""
    return trained_marker_copy(lab)


def true_stereo_yaml(lab, path):
    from core.virtual_lab.lab import DEFAULT_BOARD

    rig = lab.rig
    size = (rig.left.width, rig.left.height)
    R1, R2, P1, P2, Q, *_ = cv2.stereoRectify(rig.left.K, rig.left.dist, rig.right.K, rig.right.dist, size,
                                              rig.R, rig.T.reshape(3, 1), flags=cv2.CALIB_ZERO_DISPARITY, alpha=0)
    data = StereoFile(size, rig.left.K, rig.left.dist, rig.right.K, rig.right.dist, rig.R, rig.T,
                      rig.essential(), rig.fundamental(), R1, R2, P1, P2, Q, 0.02, 0.02, 0.03, DEFAULT_BOARD)
    return write_stereo_yaml(path, data)


def lab_state(lab, *, stereo: bool = True):
    """A WizardState on a temporary virtual-lab project with the educational 6R arm, the lab
    adopted (its robot connection: a SimulatedRobot over the lab's true robot)."""
    from app.state import WizardState

    state = WizardState(seed=0, noise=0.5)
    state.temporary_project()
    state.choose_preset("educational_6r")
    state.labs.adopt_matching(lab)
    assert state.labs.built and state.labs.ready_now() is lab
    if stereo:
        true_stereo_yaml(lab, state.project.path("stereo"))
    return state


def marker_dataset(root, poses: int = 6, seed: int = 3):
    """A `robocal simulate` dataset without checkerboards (`poses` marker pairs) and its true
    stereo.yaml; returns the dataset folder."""
    import json

    from core.camera import CameraModel
    from core.stereo.board import Board
    from core.stereo.rectification import StereoRectification
    from core.stereo.rig import StereoRig
    from core.virtual_lab.dataset import simulate_dataset

    out = root / "ds"
    simulate_dataset(out, seed=seed, pairs=0, poses=poses)
    truth = json.loads((out / "truth.json").read_text())
    s, b = truth["stereo"], truth["board"]
    size = (s["image_width"], s["image_height"])
    rig = StereoRig(CameraModel(s["K1"], s["D1"], *size), CameraModel(s["K2"], s["D2"], *size), s["R"], s["T"])
    rect = StereoRectification.from_rig(rig)
    write_stereo_yaml(out / "stereo.yaml", StereoFile(
        size, rig.left.K, rig.left.dist, rig.right.K, rig.right.dist, rig.R, rig.T, rig.essential(),
        rig.fundamental(), rect.R1, rect.R2, rect.P1, rect.P2, rect.Q, 0.0, 0.0, 0.0,
        Board(b["cols"], b["rows"], b["square"])))
    return out
