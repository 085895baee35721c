"""Measurement files with the optional orientation columns rx, ry, rz, srx, sry, srz (deg)."""
from __future__ import annotations

import numpy as np
import pytest

from core.errors import RoboCalError
from core.measurement.file import MeasurementWriter, Measurements, read_measurements, write_measurements

HEADER = "pose,target,q1,q2,x,y,z,sx,sy,sz,rx,ry,rz,srx,sry,srz"


def test_a_file_written_from_the_format_reads_with_and_without_orientation(tmp_path):
    path = tmp_path / "m.csv"
    path.write_text("# robocal.measurements/1.1\n" + HEADER + "\n"
                    "0,marker,10,20,1,2,3,0.01,0.01,0.02,90,0,0,0.01,0.02,0.03\n"
                    "1,marker,11,21,4,5,6,0.01,0.01,0.02,,,,,,\n")
    m = read_measurements(path)
    np.testing.assert_allclose(m.rotation[0], [np.pi / 2, 0, 0])
    np.testing.assert_allclose(m.rotation_sigma[0], np.deg2rad([0.01, 0.02, 0.03]))
    assert list(m.has_orientation) == [True, False] and np.all(np.isnan(m.rotation[1]))
    old = tmp_path / "old.csv"
    old.write_text("# robocal.measurements/1\npose,target,q1,q2,x,y,z\n0,marker,10,20,1,2,3\n")
    m_old = read_measurements(old)
    assert m_old.rotation is None and m_old.rotation_sigma is None and not m_old.has_orientation.any()


def test_round_trip(tmp_path):
    rng = np.random.default_rng(0)
    rot = rng.uniform(-2, 2, (3, 3))
    rot[1] = np.nan
    meas = Measurements(pose=[0, 1, 2], target=["marker"] * 3, q_file=rng.uniform(-90, 90, (3, 2)),
                        xyz=rng.uniform(-500, 500, (3, 3)), sigma=np.full((3, 3), 0.01),
                        rotation=rot, rotation_sigma=np.where(np.isnan(rot), np.nan, 1e-3))
    path = write_measurements(meas, tmp_path / "m.csv")
    assert path.read_text().startswith("# robocal.measurements/1.1 ")
    back = read_measurements(path)
    np.testing.assert_allclose(back.rotation[[0, 2]], rot[[0, 2]], atol=1e-7)       # 1e-6 deg written
    np.testing.assert_allclose(back.rotation_sigma[[0, 2]], 1e-3, atol=1e-7)
    assert list(back.has_orientation) == [True, False, True]
    assert back.subset([2]).rotation.shape == (1, 3)
    plain = Measurements(pose=[0], target=["marker"], q_file=[[1.0, 2.0]], xyz=[[1.0, 2.0, 3.0]])
    text = write_measurements(plain, tmp_path / "p.csv").read_text()
    assert text.startswith("# robocal.measurements/1 ") and "rx" not in text
    assert read_measurements(tmp_path / "p.csv").rotation is None


def test_writer_appends_orientation_or_empty_cells(tmp_path):
    path = tmp_path / "w.csv"
    with MeasurementWriter(path, dof=2, sigmas=True, orientation=True) as w:
        w.append(0, "marker", [1, 2], [3, 4, 5], [0.1, 0.1, 0.1], [10, 20, 30, 0.01, 0.01, 0.02])
        w.append(1, "marker", [1, 3], [3, 4, 6], [0.1, 0.1, 0.1])
    m = read_measurements(path)
    np.testing.assert_allclose(np.rad2deg(m.rotation[0]), [10, 20, 30])
    assert list(m.has_orientation) == [True, False]
    with MeasurementWriter(tmp_path / "n.csv", dof=2) as w, pytest.raises(RoboCalError, match="rx, ry, rz"):
        w.append(0, "marker", [1, 2], [3, 4, 5], None, [1, 2, 3, 0.1, 0.1, 0.1])


@pytest.mark.parametrize("header, row, message, line", [
    ("pose,target,q1,x,y,z,rx,ry,rz", "0,m,1,1,2,3,1,2,3", "missing column 'srx'", 2),
    ("pose,target,q1,x,y,z,rx,ry,rz,srx,sry,srz", "0,m,1,1,2,3,1,2,,0.1,0.1,0.1", "column 'rz'.*empty", 3),
    ("pose,target,q1,x,y,z,rx,ry,rz,srx,sry,srz", "0,m,1,1,2,3,1,2,3,0.1,0,0.1", "column 'sry'.*positive", 3),
    ("pose,target,q1,x,y,z,rx,ry,rz,srx,sry,srz", "0,m,1,1,2,3,1,200,3,0.1,0.1,0.1", "column 'ry'.*180", 3),
])
def test_bad_orientation_cells_are_named(tmp_path, header, row, message, line):
    path = tmp_path / "bad.csv"
    path.write_text(f"# robocal.measurements/1.1\n{header}\n{row}\n")
    with pytest.raises(RoboCalError, match=message) as info:
        read_measurements(path)
    assert f"line {line}" in str(info.value)
