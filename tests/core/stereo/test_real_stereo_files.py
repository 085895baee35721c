"""Stereo calibrations written by other people's tools (sources, commits and licences in
tests/data/real/README.md), read by RoboCal and by pyyaml: the Kalibr camchain of the EuRoC MAV
pair (equidistant lenses) and the ROS camera_info pair of a ZED camera."""
from __future__ import annotations

import hashlib
from pathlib import Path

import numpy as np
import pytest
import yaml

from app.cli import main
from core.errors import RoboCalError
from core.stereo.importers import read_any_stereo
from core.stereo.importers.kalibr import _cam1_from_cam0

REAL = Path(__file__).resolve().parents[2] / "data" / "real"
EUROC = REAL / "euroc_camchain_equidistant.yaml"
ZED = REAL / "ros_zed"


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
