"""A Kalibr camchain from a real lab (the EuRoC MAV stereo pair, equidistant lenses; source,
commit and licence in tests/data/real/README.md), read by RoboCal and by pyyaml."""
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

EUROC = Path(__file__).resolve().parents[2] / "data" / "real" / "euroc_camchain_equidistant.yaml"


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
