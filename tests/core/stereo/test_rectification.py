"""The rectification of a stereo pair: the layout checks of the marker location, the maps
between raw and rectified pixels, and stereo.yaml -> rectification."""
from __future__ import annotations

import copy

import cv2
import numpy as np
import pytest

from core.camera import CameraModel
from core.errors import RoboCalError
from core.stereo.board import Board
from core.stereo.file import StereoFile, write_stereo_yaml
from core.stereo.rectification import StereoRectification, load_rectification
from core.stereo.rig import StereoRig

W, H = 640, 480
F = 800.0
B = 100.0


def ideal_rectification() -> StereoRectification:
    """An ideal rectified pair: rectified pixels are raw pixels."""
    K = np.array([[F, 0, 319.5], [0, F, 239.5], [0, 0, 1]])
    cam = CameraModel(K, np.zeros(5), W, H)
    rig = StereoRig(cam, cam, np.eye(3), [-B, 0, 0])
    P1 = np.hstack([K, np.zeros((3, 1))])
    P2 = P1.copy()
    P2[0, 3] = -F * B
    return StereoRectification(rig, np.eye(3), np.eye(3), P1, P2)


def test_rig_orientation_checks():
    rect = ideal_rectification()
    rig = rect.rig
    P1 = rect.P1
    vertical = P1.copy()
    vertical[1, 3] = -F * B
    with pytest.raises(RoboCalError, match="one above the other"):
        StereoRectification(rig, np.eye(3), np.eye(3), P1, vertical)
    swapped = P1.copy()
    swapped[0, 3] = F * B
    with pytest.raises(RoboCalError, match="on the left"):
        StereoRectification(rig, np.eye(3), np.eye(3), P1, swapped)


def test_from_rig_and_rectified_images():
    from core.virtual_lab.rig import default_rig
    rig = default_rig(0)
    rect = StereoRectification.from_rig(rig)
    assert rect.baseline == pytest.approx(rig.baseline, rel=1e-6)
    assert rect.disparity_offset == pytest.approx(0.0, abs=1e-9)
    P = np.array([[30.0, -20.0, 700.0]])
    ul = rect.left_map.to_ideal(rig.left.project(P))[0]
    ur = rect.right_map.to_ideal(rig.right.project(rig.to_right(P)))[0]
    assert ul[1] == pytest.approx(ur[1], abs=1e-6)                       # same row
    assert rect.disparity_of_depth(700.0) == pytest.approx(ul[0] - ur[0], rel=1e-3)
    np.testing.assert_allclose(rect.left_map.to_raw(ul[None])[0], rig.left.project(P)[0], atol=1e-6)
    img = np.zeros((rig.left.height, rig.left.width), np.uint8)
    a, b = rect.rectify(img, img)
    assert a.shape == img.shape and b.shape == img.shape


def _stereo_file(rig: StereoRig) -> StereoFile:
    R1, R2, P1, P2, Q, *_ = cv2.stereoRectify(rig.left.K, rig.left.dist, rig.right.K, rig.right.dist, rig.left.size,
                                              rig.R, rig.T.reshape(3, 1), flags=cv2.CALIB_ZERO_DISPARITY, alpha=0)
    return StereoFile(rig.left.size, rig.left.K, rig.left.dist, rig.right.K, rig.right.dist, rig.R, rig.T,
                      rig.essential(), rig.fundamental(), R1, R2, P1, P2, Q, 0.02, 0.02, 0.03, Board(9, 6, 24.0))


def test_load_rectification_of_a_stereo_yaml(tmp_path):
    from core.virtual_lab.rig import default_rig
    rig = default_rig(0)
    path = write_stereo_yaml(tmp_path / "stereo.yaml", _stereo_file(rig))
    rect = load_rectification(path)
    same = StereoRectification.from_rig(rig)
    for key in ("R1", "R2", "P1", "P2"):
        np.testing.assert_allclose(getattr(rect, key), getattr(same, key), atol=1e-9)
    assert rect.calibration.rms_stereo == pytest.approx(0.03)
    assert rect.baseline == pytest.approx(rig.baseline, rel=1e-6)


def test_load_rectification_refuses_a_rig_the_marker_location_cannot_use(tmp_path):
    from core.virtual_lab.rig import default_rig
    rig = default_rig(0)
    # the same cameras with left and right exchanged: the 'right' camera is on the left
    swapped = _stereo_file(StereoRig(rig.right, rig.left, rig.R.T, -rig.R.T @ rig.T))
    with pytest.raises(RoboCalError, match="on the left"):
        load_rectification(write_stereo_yaml(tmp_path / "swapped.yaml", swapped))
    shown = StereoRectification.from_calibration(copy.deepcopy(swapped), for_location=False)
    assert not shown.vertical and shown.P2[0, 3] > 0          # a calibration result shows any rig
