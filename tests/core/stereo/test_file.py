"""stereo.yaml: round trip, readable by cv2.FileStorage, atomic write, clear read errors;
ROS camera_info and JSON exports."""
import copy
import json
import os
import re

import cv2
import numpy as np
import pytest
import yaml

from core.errors import RoboCalError
from core.stereo.calibration import calibrate_points
from core.stereo.fit import CalibrationOptions
from core.stereo.point_uncertainty import parameter_covariance
from core.stereo.file import (FORMAT, StereoFile, camera_info_yaml, read_stereo_yaml, stereo_json,
                              write_ros_camera_info, write_stereo_json, write_stereo_yaml)
from tests.core.stereo_synth import BOARD, SIZE, synthetic_views


@pytest.fixture(scope="module")
def result():
    _, left, right = synthetic_views(10, noise=0.03, seed=11)
    return calibrate_points(left, right, BOARD, SIZE)


@pytest.fixture(scope="module")
def rational():
    _, left, right = synthetic_views(10, noise=0.03, seed=11)
    return calibrate_points(left, right, BOARD, SIZE, CalibrationOptions(radial=6, cross_validate=False))


def test_round_trip(tmp_path, result):
    path = write_stereo_yaml(tmp_path / "stereo.yaml", result)
    sf = read_stereo_yaml(path)
    assert sf.image_size == SIZE and sf.board == BOARD
    for key in ("K1", "D1", "K2", "D2", "R", "E", "F", "R1", "R2", "P1", "P2", "Q"):
        expected = getattr(result.file, key)
        np.testing.assert_allclose(getattr(sf, key), np.asarray(expected).reshape(getattr(sf, key).shape),
                                   rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(sf.T, result.file.T)
    assert sf.rms_stereo == pytest.approx(result.file.rms_stereo)
    assert sf.extras["epipolar_rms"] == pytest.approx(result.epipolar_rms)
    assert sf.rectify_alpha == 0.0
    assert sf.rig.baseline == pytest.approx(result.baseline_mm)
    again = tmp_path / "again.yaml"
    write_stereo_yaml(again, sf)
    assert read_stereo_yaml(again).to_dict() == sf.to_dict()


def test_readable_by_plain_opencv(tmp_path, result):
    path = write_stereo_yaml(tmp_path / "stereo.yaml", result)
    fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_READ)
    assert fs.getNode("format").string() == FORMAT
    assert int(fs.getNode("image_width").real()) == SIZE[0]
    assert fs.getNode("K1").mat().shape == (3, 3)
    assert fs.getNode("D1").mat().shape == (1, 5)
    assert fs.getNode("T").mat().shape == (3, 1)
    assert fs.getNode("Q").mat().shape == (4, 4)
    for key in ("rms_left", "rms_right", "rms_stereo", "board_square"):
        assert fs.getNode(key).isReal()
    assert int(fs.getNode("board_cols").real()) == 9 and int(fs.getNode("board_rows").real()) == 6
    fs.release()


def test_failed_write_keeps_the_previous_file(tmp_path, result, monkeypatch):
    path = tmp_path / "stereo.yaml"
    write_stereo_yaml(path, result)
    before = path.read_bytes()

    def boom(*args):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(os, "replace", boom)
    with pytest.raises(RoboCalError, match="cannot write"):
        write_stereo_yaml(path, result)
    monkeypatch.undo()
    assert path.read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["stereo.yaml"]      # no temp file left


def _write_text(tmp_path, text, name="s.yaml"):
    p = tmp_path / name
    p.write_text(text)
    return p


def _good_text(tmp_path, result):
    return write_stereo_yaml(tmp_path / "good.yaml", result).read_text()


def test_read_errors_name_the_field(tmp_path, result):
    text = _good_text(tmp_path, result)
    no_q = re.sub(r"Q: !!opencv-matrix\n(   .*\n)+", "", text)
    with pytest.raises(RoboCalError, match="field 'Q': missing"):
        read_stereo_yaml(_write_text(tmp_path, no_q))
    wrong = text.replace("format: \"robocal.stereo/1\"", "format: \"robocal.stereo/2\"")
    with pytest.raises(RoboCalError, match="unknown format version 2"):
        read_stereo_yaml(_write_text(tmp_path, wrong))
    other = text.replace("robocal.stereo/1", "robocal.robot/1")
    with pytest.raises(RoboCalError, match="'robocal.robot' file"):
        read_stereo_yaml(_write_text(tmp_path, other))
    untagged = text.replace("format: \"robocal.stereo/1\"\n", "")
    with pytest.raises(RoboCalError, match="field 'format': missing"):
        read_stereo_yaml(_write_text(tmp_path, untagged))
    shape = re.sub(r"(K1: !!opencv-matrix\n   rows: )3", r"\g<1>1", text)
    shape = re.sub(r"(K1: !!opencv-matrix\n   rows: 1\n   cols: )3", r"\g<1>9", shape)
    with pytest.raises(RoboCalError, match="field 'K1': expected a 3x3 matrix, got 1x9"):
        read_stereo_yaml(_write_text(tmp_path, shape))
    text_width = text.replace("image_width: 1280", "image_width: wide")
    with pytest.raises(RoboCalError, match="field 'image_width'"):
        read_stereo_yaml(_write_text(tmp_path, text_width))


def test_rectify_alpha_is_stored(tmp_path):
    _, left, right = synthetic_views(8, noise=0.03, seed=5)
    half = calibrate_points(left, right, BOARD, SIZE, CalibrationOptions(rectify_alpha=0.5, cross_validate=False))
    path = write_stereo_yaml(tmp_path / "stereo.yaml", half)
    fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_READ)
    assert fs.getNode("rectify_alpha").real() == 0.5
    fs.release()
    assert read_stereo_yaml(path).rectify_alpha == 0.5 and stereo_json(half)["rectify_alpha"] == 0.5
    text = path.read_text()
    older = re.sub(r"rectify_alpha: .*\n", "", text)                  # files written before alpha was stored
    assert older != text and read_stereo_yaml(_write_text(tmp_path, older)).rectify_alpha == 0.0
    with pytest.raises(RoboCalError, match="field 'rectify_alpha': expected a value from 0 to 1, got 2"):
        read_stereo_yaml(_write_text(tmp_path, text.replace("rectify_alpha: 0.5", "rectify_alpha: 2.")))


def test_read_errors_for_bad_files(tmp_path):
    with pytest.raises(RoboCalError, match="file not found"):
        read_stereo_yaml(tmp_path / "none.yaml")
    with pytest.raises(RoboCalError, match="not a readable OpenCV YAML"):
        read_stereo_yaml(_write_text(tmp_path, "%YAML:1.0\n---\nK1: [1, 2\n"))
    binary = tmp_path / "b.yaml"
    binary.write_bytes(b"\x00\x01garbage")
    with pytest.raises(RoboCalError, match="not a YAML file"):
        read_stereo_yaml(binary)
    with pytest.raises(RoboCalError, match="top level"):
        read_stereo_yaml(_write_text(tmp_path, "%YAML:1.0\n---\n- 1\n- 2\n"))


def test_rotation_checked(tmp_path, result):
    sf = copy.deepcopy(result.file)
    sf.R = sf.R * 1.1
    path = write_stereo_yaml(tmp_path / "bad.yaml", sf)
    with pytest.raises(RoboCalError, match="field 'R': not a rotation matrix"):
        read_stereo_yaml(path)


def _ros(text):
    """camera_info YAML read by an independent reader (pyyaml)."""
    return yaml.safe_load(text)


def test_ros_camera_info_export(tmp_path, result, rational):
    left, right = write_ros_camera_info(tmp_path / "ros", result)
    assert left.name == "left.yaml" and right.name == "right.yaml"
    f = _ros(right.read_text())
    assert list(f) == ["image_width", "image_height", "camera_name", "camera_matrix", "distortion_model",
                       "distortion_coefficients", "rectification_matrix", "projection_matrix"]
    assert f["image_width"] == 1280 and f["camera_name"] == "right"
    assert f["distortion_model"] == "plumb_bob" and f["distortion_coefficients"]["cols"] == 5
    np.testing.assert_allclose(np.reshape(f["camera_matrix"]["data"], (3, 3)), result.file.K2)
    P = np.reshape(f["projection_matrix"]["data"], (3, 4))
    P2 = result.rectification.P2
    np.testing.assert_allclose(P[:, :3], P2[:, :3])
    assert P[0, 3] == pytest.approx(P2[0, 3] / 1000.0)          # ROS: metres
    assert P[0, 3] / P[0, 0] == pytest.approx(-result.baseline_mm / 1000, rel=0.01)
    g = _ros(camera_info_yaml(rational, "left"))
    assert g["distortion_model"] == "rational_polynomial" and len(g["distortion_coefficients"]["data"]) == 8


MATRICES = ("camera_matrix", "distortion_coefficients", "rectification_matrix", "projection_matrix")


@pytest.mark.parametrize("fixture", ["result", "rational"])
def test_ros_camera_info_entries_are_floats(tmp_path, request, fixture):
    for path in write_ros_camera_info(tmp_path, request.getfixturevalue(fixture)):
        f = _ros(path.read_text())
        for key in MATRICES:
            data = f[key]["data"]
            assert len(data) == f[key]["rows"] * f[key]["cols"]
            assert all(type(v) is float for v in data), (path.name, key, data)   # ROS 2 setters take floats
        assert type(f["image_width"]) is int and type(f["image_height"]) is int


def test_ros_number_text_reads_back_exactly():
    values = [0.0, -0.0, 1.0, -2.5, 1e-05, -3e-12, 1.5e-07, 1e16, 123456789.123, 1 / 3]
    eye = np.eye(3)
    sf = StereoFile((4, 4), K1=eye, D1=np.array(values[:5]), K2=eye, D2=np.array(values[5:]), R=eye,
                    T=np.zeros(3), E=eye, F=eye, R1=eye, R2=eye, P1=np.eye(3, 4), P2=np.eye(3, 4), Q=np.eye(4),
                    rms_left=0.0, rms_right=0.0, rms_stereo=0.0, board=BOARD)
    for side, expected in (("left", values[:5]), ("right", values[5:])):
        text = camera_info_yaml(sf, side)
        got = _ros(text)["distortion_coefficients"]["data"]
        assert got == expected and all(type(v) is float for v in got)
        assert "-0.0" not in text                 # pyyaml would read "1e-05" as text, "0" as an int


def _opencv_file(path):
    """stereo.yaml read by plain cv2.FileStorage."""
    fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_READ)
    out = {k: fs.getNode(k).mat() for k in ("K1", "D1", "K2", "D2", "R", "T", "R1", "R2", "P1", "P2")}
    fs.release()
    return out


@pytest.mark.parametrize("fixture", ["result", "rational"])
def test_ros_files_reproject_like_stereo_yaml(tmp_path, request, fixture):
    data = request.getfixturevalue(fixture)
    cv = _opencv_file(write_stereo_yaml(tmp_path / "stereo.yaml", data))
    ros = {side: _ros(p.read_text()) for side, p in zip(("left", "right"), write_ros_camera_info(tmp_path, data))}
    rng = np.random.default_rng(3)
    X = np.column_stack([rng.uniform(-300, 300, 50), rng.uniform(-250, 250, 50), rng.uniform(900, 1600, 50)])
    criteria = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 200, 1e-15)
    rect_left = np.reshape(ros["left"]["rectification_matrix"]["data"], (3, 3))
    for side, (K, D, R, P) in {"left": ("K1", "D1", "R1", "P1"), "right": ("K2", "D2", "R2", "P2")}.items():
        m = {k: np.reshape(ros[side][k]["data"], (ros[side][k]["rows"], ros[side][k]["cols"])) for k in MATRICES}
        # the camera's own pixels of X (X in the left camera frame, mm)
        rvec = np.zeros(3) if side == "left" else cv2.Rodrigues(cv["R"])[0]
        tvec = np.zeros(3) if side == "left" else cv["T"]
        pixels = cv2.projectPoints(X, rvec, tvec, cv[K], cv[D])[0]
        # rectified with the ROS file and with stereo.yaml
        by_ros = cv2.undistortPoints(pixels, m["camera_matrix"], m["distortion_coefficients"],
                                     R=m["rectification_matrix"], P=m["projection_matrix"],
                                     criteria=criteria).reshape(-1, 2)
        by_yaml = cv2.undistortPoints(pixels, cv[K], cv[D], R=cv[R], P=cv[P], criteria=criteria).reshape(-1, 2)
        np.testing.assert_array_equal(by_ros, by_yaml)                   # the same numbers, read back exactly
        # ROS's projection of X: metres, in the rectified left frame (both cameras), translation included
        h = m["projection_matrix"] @ np.vstack([rect_left @ X.T / 1000.0, np.ones(len(X))])
        np.testing.assert_allclose((h[:2] / h[2]).T, by_yaml, rtol=0, atol=2e-11)    # px; seen: 3e-12


def test_json_export(tmp_path, result):
    path = write_stereo_json(tmp_path / "stereo.json", result)
    data = json.loads(path.read_text())
    assert data["format"] == FORMAT and data["board_cols"] == 9
    assert np.allclose(data["K1"], result.file.K1)
    assert data["calibration"]["pairs_used"] == 10
    assert len(data["views"]) == 10 and {"rms_left", "rms_right", "outlier"} <= set(data["views"][0])
    assert any(p["name"] == "baseline" and p["std"] > 0 for p in data["parameters"])
    kept = parameter_covariance(path, result.file.K1, result.file.K2, result.file.T)     # read back for its own file
    np.testing.assert_allclose(kept, result.covariance, rtol=1e-12)
    plain = stereo_json(result.file)
    assert "calibration" not in plain


def test_rational_model_reaches_the_marker_step(tmp_path, rational):
    """A stereo.yaml with k4..k6 keeps all 8 coefficients in its rig and rectifies for the marker step."""
    from core.marker.correspondence import StereoRectification

    sf = read_stereo_yaml(write_stereo_yaml(tmp_path / "stereo.yaml", rational))
    assert np.any(sf.D1[5:] != 0)
    np.testing.assert_array_equal(sf.rig.left.dist, sf.D1.ravel()[:8])
    np.testing.assert_array_equal(sf.rig.right.dist, sf.D2.ravel()[:8])
    rect = StereoRectification.from_calibration(sf)
    np.testing.assert_allclose(rect.P1, sf.P1)
    assert rect.baseline == pytest.approx(sf.baseline_mm, rel=0.01)
