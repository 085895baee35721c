"""core.measurement.importer: CSVs from laser trackers and other tools, any column order and units."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from core.errors import RoboCalError
from core.measurement.file import read_measurements, write_measurements
from core.measurement.importer import import_measurements
from core.robot.file import read_robot
from core.robot.model import robot_path
from core.virtual_lab.synthetic import perturbed_model, simulate_measurements

IRB = Path(__file__).resolve().parents[4] / "shared" / "data" / "irb120-laser-tracker"


@pytest.fixture(scope="module")
def synthetic():
    robot = read_robot(robot_path("educational_6r"))
    robot.targets["probe"] = np.array([10.0, 0.0, 80.0])
    return simulate_measurements(perturbed_model(robot, 1), 8, targets=["marker", "probe"], rng=2)


def write_foreign(path: Path, meas, *, sep=";", length="m", angle="rad", suffixes=True, pose=True, target=True):
    """The measurements as another tool might write them: shuffled columns, other units and names."""
    qs = [f"joint_{k + 1}" + (f"_{angle}" if suffixes else "") for k in range(meas.dof)]
    xyz = [f"{a}{'_' + length if suffixes else ''}" for a in ("X", "Y", "Z")]
    header = xyz[::-1] + (["Reflector"] if target else []) + qs + (["Pose ID"] if pose else [])
    q = np.deg2rad(meas.q_file) if angle == "rad" else meas.q_file
    s = 1e-3 if length == "m" else 1.0
    rows = [sep.join(header)]
    for i in range(meas.n_points):
        cells = [repr(float(v * s)) for v in meas.xyz[i][::-1]] + ([meas.target[i]] if target else []) \
            + [repr(float(v)) for v in q[i]] + ([str(meas.pose[i])] if pose else [])
        rows.append(sep.join(cells))
    path.write_text("# exported by a tracker\n" + "\n".join(rows) + "\n")
    return path


def test_any_column_order_separator_and_units(synthetic, tmp_path):
    src = write_foreign(tmp_path / "tracker.csv", synthetic)
    got = import_measurements([src]).measurements
    assert list(got.pose) == list(synthetic.pose) and got.target == synthetic.target
    np.testing.assert_allclose(got.q_file, synthetic.q_file, atol=1e-9)
    np.testing.assert_allclose(got.xyz, synthetic.xyz, atol=1e-9)


def test_units_from_the_command_line_when_columns_do_not_say(synthetic, tmp_path):
    src = write_foreign(tmp_path / "t.csv", synthetic, sep=",", suffixes=False)
    got = import_measurements([src], length_unit="m", angle_unit="rad").measurements
    np.testing.assert_allclose(got.xyz, synthetic.xyz, atol=1e-9)
    with pytest.raises(RoboCalError, match="they look like metres. Give --length-unit m") as info:
        import_measurements([src], angle_unit="rad")               # metres read as mm: refused, not imported
    assert info.value.source == str(src) and info.value.field == "x, y, z"
    mm = write_foreign(tmp_path / "mm.csv", synthetic, sep=",", length="mm", suffixes=False)
    np.testing.assert_allclose(import_measurements([mm], angle_unit="rad").measurements.xyz, synthetic.xyz, atol=1e-9)


def test_a_column_unit_that_contradicts_the_given_unit_is_refused(synthetic, tmp_path):
    src = write_foreign(tmp_path / "t.csv", synthetic)
    with pytest.raises(RoboCalError, match="field 'Z_m': the column says m but the length unit given is mm") as info:
        import_measurements([src], length_unit="mm")
    assert "t.csv" in str(info.value)


def test_without_pose_and_target_columns(synthetic, tmp_path):
    src = write_foreign(tmp_path / "t.csv", synthetic, pose=False, target=False)
    with pytest.raises(RoboCalError, match="pose 0 target 'marker' appears twice"):
        import_measurements([src])                  # two targets per pose but no target column
    one = synthetic.subset(np.array(synthetic.target) == "marker")
    src = write_foreign(tmp_path / "m.csv", one, pose=False, target=False)
    got = import_measurements([src], target="tip")
    assert got.measurements.n_poses == one.n_poses and set(got.measurements.target) == {"tip"}
    assert any("no pose column" in n for n in got.notes)


def test_pose_ids_may_not_repeat_across_files(synthetic, tmp_path):
    a = write_foreign(tmp_path / "a.csv", synthetic)
    b = write_foreign(tmp_path / "b.csv", synthetic)
    with pytest.raises(RoboCalError, match="pose 0 is also in a.csv"):
        import_measurements([a, b])


@pytest.mark.skipif(not IRB.is_dir(), reason=f"IRB 120 laser-tracker data not found at {IRB}")
def test_real_irb120_laser_tracker_files(tmp_path):
    imported = import_measurements([IRB / "calibration.csv", IRB / "test_points_at_zero.csv"])
    meas = imported.measurements
    assert (meas.n_points, meas.n_poses, meas.target_names) == (110, 38, ["p1", "p2", "p3", "t1", "t2"])
    write_measurements(meas, tmp_path / "m.csv")
    back = read_measurements(tmp_path / "m.csv")
    raw = np.loadtxt(IRB / "calibration.csv", delimiter=",", skiprows=1, usecols=range(2, 11))
    np.testing.assert_allclose(back.q_file[:108], raw[:, :6], atol=1e-6)
    np.testing.assert_allclose(back.xyz[:108], raw[:, 6:], atol=1e-6)
