"""Stereo calibrations written by other people's tools (sources, commits and licences in
tests/data/real/README.md), read by RoboCal and by an independent reader: the Kalibr camchain of
the EuRoC MAV pair (equidistant lenses) and the ROS camera_info pair of a ZED camera by pyyaml,
OpenCV stereo_calib's intrinsics.yml + extrinsics.yml of a structured-light scanner and the
rectification-only pair of MultiSense's ImageCalUtility by cv2.FileStorage."""
from __future__ import annotations

import hashlib
from pathlib import Path

import cv2
import numpy as np
import pytest
import yaml

from app.cli import main
from core.errors import RoboCalError
from core.stereo.importers import read_any_stereo
from core.stereo.importers.kalibr import _cam1_from_cam0
from core.stereo.rectification import load_rectification

REAL = Path(__file__).resolve().parents[2] / "data" / "real"
EUROC = REAL / "euroc_camchain_equidistant.yaml"
ZED = REAL / "ros_zed"
UNLOOK = REAL / "opencv_unlook"
MULTISENSE = REAL / "multisense_imagecal"


def test_equidistant_lenses_are_refused_with_what_to_do(tmp_path, capsys):
    with pytest.raises(RoboCalError) as err:
        read_any_stereo(EUROC)
    assert err.value.field == "cam0.distortion_model" and "equidistant (fisheye)" in err.value.problem
    assert "pinhole-radtan" in err.value.hint and "robocal stereo-calibrate" in err.value.hint
    before = hashlib.sha256(EUROC.read_bytes()).hexdigest()
    assert main(["stereo-import", str(EUROC), "--out", str(tmp_path / "stereo.yaml")]) == 1
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and str(EUROC) in lines[0] and "equidistant" in lines[0]
    assert hashlib.sha256(EUROC.read_bytes()).hexdigest() == before and not (tmp_path / "stereo.yaml").exists()


def test_the_pose_through_the_imu_equals_kalibrs_own_camera_to_camera_pose():
    """Kalibr wrote both cameras' T_cam_imu and cam1's T_cn_cnm1: composed without T_cn_cnm1,
    RoboCal's pose of cam1 from cam0 equals the one pyyaml reads from the file."""
    data = yaml.safe_load(EUROC.read_text())
    given = np.array(data["cam1"].pop("T_cn_cnm1"), dtype=float)
    composed, field, note = _cam1_from_cam0(data["cam0"], data["cam1"], EUROC)
    assert field == "cam1.T_cam_imu" and "T_cam1_imu · T_cam0_imu⁻¹" in note
    np.testing.assert_allclose(composed, given, atol=1e-12)
    assert np.linalg.norm(given[:3, 3]) * 1000 == pytest.approx(110.066, abs=0.001)    # the EuRoC baseline, mm


def _ros(path: Path) -> dict:
    data = yaml.safe_load(path.read_text())
    return {k: np.array(data[k]["data"], float).reshape(data[k]["rows"], data[k]["cols"])
            for k in ("camera_matrix", "distortion_coefficients", "rectification_matrix", "projection_matrix")} | {
        "size": (data["image_width"], data["image_height"])}


def test_a_ros_camera_info_pair_printed_with_six_decimals(tmp_path):
    imported = read_any_stereo(ZED)
    left, right = _ros(ZED / "left.yaml"), _ros(ZED / "right.yaml")
    sf = imported.file
    assert imported.kind == "ROS camera_info pair" and sf.image_size == left["size"] == right["size"]
    np.testing.assert_array_equal(sf.K1, left["camera_matrix"])
    np.testing.assert_array_equal(sf.K2, right["camera_matrix"])
    np.testing.assert_array_equal(np.ravel(sf.D1), left["distortion_coefficients"].ravel())
    np.testing.assert_array_equal(np.ravel(sf.D2), right["distortion_coefficients"].ravel())
    R1, R2 = left["rectification_matrix"], right["rectification_matrix"]
    np.testing.assert_allclose(sf.R, R2.T @ R1, atol=5e-6)          # the file's six decimals
    baseline_mm = -right["projection_matrix"][0, 3] / right["projection_matrix"][0, 0] * 1000.0
    np.testing.assert_allclose(sf.T, R2.T @ [-baseline_mm, 0.0, 0.0], atol=5e-3)
    assert sf.baseline_mm == pytest.approx(baseline_mm, abs=1e-3)
    assert any("printed with few decimals" in n for n in imported.notes)
    assert main(["stereo-import", str(ZED / "left.yaml"), str(ZED / "right.yaml"), "--out",
                 str(tmp_path / "stereo.yaml")]) == 0
    back = read_any_stereo(tmp_path / "stereo.yaml").file
    np.testing.assert_allclose(back.T, sf.T, atol=1e-9)


def _storage(path: Path) -> dict:
    fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_READ)
    try:
        return {k: fs.getNode(k).mat() for k in fs.root().keys()}
    finally:
        fs.release()


def test_opencv_stereo_calib_pair_with_the_rational_model_and_swapped_cameras(tmp_path, capsys):
    """stereo_calib's two files as a scanner's calibration tool wrote them (14 distortion
    coefficients, k6 set; T_x > 0: the second camera on the left): RoboCal's numbers are
    cv2.FileStorage's; the converted file says the marker location will refuse the rig, and
    the location refuses it in one line naming the calibration and what to do."""
    cams, pose = _storage(UNLOOK / "intrinsics.yml"), _storage(UNLOOK / "extrinsics.yml")
    for given in (UNLOOK, [UNLOOK / "intrinsics.yml", UNLOOK / "extrinsics.yml"], UNLOOK / "extrinsics.yml"):
        imported = read_any_stereo(given)
        sf = imported.file
        assert imported.kind == "OpenCV stereo_calib intrinsics + extrinsics"
        np.testing.assert_array_equal(sf.K1, cams["M1"])
        np.testing.assert_array_equal(sf.K2, cams["M2"])
        np.testing.assert_array_equal(np.ravel(sf.D1), cams["D1"].ravel())
        np.testing.assert_array_equal(np.ravel(sf.D2), cams["D2"].ravel())
        for key in ("R", "R1", "R2", "P1", "P2", "Q"):
            np.testing.assert_array_equal(getattr(sf, key), pose[key])
        np.testing.assert_array_equal(sf.T, pose["T"].ravel())                        # mm, as calibrated
        assert sf.baseline_mm == pytest.approx(np.linalg.norm(pose["T"]), rel=1e-12)
        assert sf.image_size == (1280, 720) and any("no image size" in n for n in imported.notes)
    assert pose["T"][0, 0] > 0 and pose["P2"][0, 3] > 0                            # the swapped rig, as written
    with pytest.raises(RoboCalError, match=r"'right' camera is on the left.*Swap the left and right images"):
        load_rectification(UNLOOK)
    before = {p.name: p.read_bytes() for p in UNLOOK.iterdir()}
    out = tmp_path / "stereo.yaml"
    assert main(["stereo-import", str(UNLOOK), "--out", str(out), "--image-size", "1280x720"]) == 0
    text = capsys.readouterr().out
    assert "baseline 69.60 mm" in text and "the marker location will refuse this calibration" in text
    np.testing.assert_array_equal(read_any_stereo(out).file.D1, read_any_stereo(UNLOOK).file.D1)
    marker = Path(__file__).resolve().parents[3] / "resources" / "markers" / "default.png"   # a real image for every input
    code = main(["locate", "--stereo", str(out), "--marker", str(marker), "--left", str(marker),
                 "--right", str(marker)])
    lines = capsys.readouterr().err.strip().splitlines()
    assert code == 1 and len(lines) == 1 and str(out) in lines[0] and "Swap the left and right" in lines[0]
    assert {p.name: p.read_bytes() for p in UNLOOK.iterdir()} == before


def test_a_multisense_pair_whose_pose_is_only_in_its_rectification(tmp_path, capsys):
    """ImageCalUtility writes M1 D1 M2 D2 (8 coefficients) and R1 P1 R2 P2 with no R, T, lengths
    in metres: RoboCal's pose is R2ᵀ·R1 and R2ᵀ·(t2 − t1) of cv2.FileStorage's matrices; read as
    millimetres the 0.07 mm baseline is refused in one line naming the file, P2 and --unit."""
    intrinsics, extrinsics = MULTISENSE / "example_intrinsics.yml", MULTISENSE / "example_extrinsics.yml"
    cams, rect = _storage(intrinsics), _storage(extrinsics)
    assert not {"R", "T"} & rect.keys()
    t1, t2 = (np.linalg.solve(rect[k][:, :3], rect[k][:, 3]) for k in ("P1", "P2"))
    R_expected = rect["R2"].T @ rect["R1"]
    T_expected_mm = rect["R2"].T @ (t2 - t1) * 1000.0
    for given in ([intrinsics, extrinsics], extrinsics, MULTISENSE):
        imported = read_any_stereo(given, mm_per_unit=1000.0)
        sf = imported.file
        np.testing.assert_array_equal(sf.K1, cams["M1"])
        np.testing.assert_array_equal(sf.K2, cams["M2"])
        np.testing.assert_array_equal(np.ravel(sf.D1), cams["D1"].ravel())
        np.testing.assert_array_equal(np.ravel(sf.D2), cams["D2"].ravel())
        np.testing.assert_array_equal(sf.R1, rect["R1"])
        np.testing.assert_array_equal(sf.R2, rect["R2"])
        np.testing.assert_array_equal(sf.P2[:, :3], rect["P2"][:, :3])
        np.testing.assert_allclose(sf.P2[:, 3], rect["P2"][:, 3] * 1000.0, rtol=1e-15)
        np.testing.assert_allclose(sf.R, R_expected, atol=1e-15)
        np.testing.assert_allclose(sf.T, T_expected_mm, rtol=1e-12)
        assert sf.baseline_mm == pytest.approx(41.660152435302734 / 594.46551513671875 * 1000, rel=1e-6)
        assert any("from the rectification R1, R2, P1, P2" in n for n in imported.notes)
    before = {p.name: p.read_bytes() for p in MULTISENSE.iterdir()}
    out = tmp_path / "stereo.yaml"
    assert main(["stereo-import", str(intrinsics), str(extrinsics), "--out", str(out)]) == 1
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and str(intrinsics) in lines[0] and "'P2'" in lines[0] and "--unit m" in lines[0]
    assert not out.exists()
    assert main(["stereo-import", str(intrinsics), str(extrinsics), "--out", str(out), "--unit", "m"]) == 0
    assert "baseline 70.08 mm" in capsys.readouterr().out
    np.testing.assert_allclose(read_any_stereo(out).file.T, T_expected_mm, rtol=1e-12)
    assert {p.name: p.read_bytes() for p in MULTISENSE.iterdir()} == before
