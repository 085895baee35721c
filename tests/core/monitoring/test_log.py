import pytest

from core.errors import RoboCalError
from core.monitoring.log import TAG, CheckLogWriter, header_columns, read_check_log


def write_two(path):
    with CheckLogWriter(path, 2) as w:
        w.point("r1", "t", 0, "marker", [10.0, -5.0], [1, 2, 3], [1.1, 2, 3], 0.1, 0.3, True)
        w.point("r1", "t", 1, "marker", [20.0, 5.0], [4, 5, 6], [4, 5, 7], 1.0, 0.3, False)
        w.overall("r1", "t", 0.71, 0.25, False)


def test_round_trip(tmp_path):
    path = tmp_path / "checks.csv"
    write_two(path)
    log = read_check_log(path)
    (check,) = log.checks
    assert log.dof == 2 and check.finished and check.within is False
    assert [p.within for p in check.points] == [True, False]
    assert check.points[1].q_file.tolist() == [20.0, 5.0] and check.rms_mm == pytest.approx(0.71)


def test_file_written_from_the_format_description(tmp_path):
    path = tmp_path / "checks.csv"
    path.write_text(TAG + "\n" + ",".join(header_columns(1)) + "\n"
                    "a,2025-01-01T10:00:00+00:00,point,3,marker,12.5,1,2,3,1,2,3.5,0.5,0.9,1,gripper,"
                    "1.2e-05,3e-07,-2e-06,1.1e-05,4e-07,9.8e-05\n"
                    "a,2025-01-01T10:00:01+00:00,point,4,marker,12.5,1,2,3,1,2,3.5,0.5,0.9,1,gripper,,,,,,\n"
                    "a,2025-01-01T10:00:09+00:00,overall,,,,,,,,,,0.5,0.8,1,gripper,,,,,,\n")
    (check,) = read_check_log(path).checks
    assert check.points[0].pose == 3 and check.points[0].predicted.tolist() == [1, 2, 3.5]
    assert check.rms_limit_mm == 0.8 and check.within
    assert check.tool == "gripper" and check.points[0].tool == "gripper"
    assert check.points[0].covariance[2, 0] == -2e-06 and check.points[0].covariance[2, 2] == 9.8e-05
    assert check.points[1].covariance is None


def test_a_points_own_covariance_is_logged_to_six_digits(tmp_path):
    import numpy as np
    path = tmp_path / "checks.csv"
    C = np.array([[1.23456789e-5, 2e-7, -3e-6], [2e-7, 1.1e-5, 4e-7], [-3e-6, 4e-7, 9.87654321e-5]])
    with CheckLogWriter(path, 1) as w:
        w.point("r", "t", 0, "marker", [1.0], [1, 2, 3], [1, 2, 3], 0.0, 0.3, True, "", C)
        w.point("r", "t", 1, "marker", [1.0], [1, 2, 3], [1, 2, 3], 0.0, 0.3, True)
    first, second = read_check_log(path).checks[0].points
    np.testing.assert_allclose(first.covariance, C, rtol=1e-5)
    assert second.covariance is None


@pytest.mark.parametrize("cov, field", [(",,,,,9e-05", "cxx"), ("1e-5,0,0,1e-5,0,x", "czz"),
                                         ("1e-5,0,0,-1e-5,0,1e-5", "cxx"), ("1e-5,2e-5,0,1e-5,0,1e-5", "cxx")])
def test_a_bad_covariance_is_named(tmp_path, cov, field):
    path = tmp_path / "checks.csv"
    path.write_text(TAG + "\n" + ",".join(header_columns(1)) + "\n"
                    f"a,2025-01-01T10:00:00+00:00,point,3,marker,12.5,1,2,3,1,2,3.5,0.5,0.9,1,gripper,{cov}\n")
    with pytest.raises(RoboCalError) as exc:
        read_check_log(path)
    assert exc.value.field == field and exc.value.source == str(path)


def test_log_without_the_covariance_columns_gains_them_when_appended_to(tmp_path):
    """A point measured with its covariance is logged with it also in a log begun before the
    columns existed, so that a re-identification from the log judges it as the check did."""
    import numpy as np
    path = tmp_path / "checks.csv"
    path.write_text(TAG + "\n# a comment kept\n" + ",".join(header_columns(1, covariance=False)) + "\n"
                    "a,2025-01-01T10:00:00+00:00,point,3,marker,12.5,1,2,3,1,2,3.5,0.5,0.9,1,gripper\n")
    log = read_check_log(path)
    assert log.tool_column and not log.covariance_columns and log.checks[0].points[0].covariance is None
    with CheckLogWriter(path, 1) as w:
        w.point("b", "t", 0, "marker", [1.0], [1, 2, 3], [1, 2, 3], 0.0, 0.3, True, "gripper", np.eye(3) * 1e-5)
    log = read_check_log(path)
    assert [c.run for c in log.checks] == ["a", "b"] and log.checks[0].points[0].tool == "gripper"
    assert log.checks[0].points[0].covariance is None
    np.testing.assert_allclose(log.checks[1].points[0].covariance, np.eye(3) * 1e-5)
    assert path.read_text().splitlines()[1] == "# a comment kept"


def test_a_matrix_that_is_no_covariance_is_logged_as_none(tmp_path):
    """A locator's covariance gone wrong (NaN, all zero) must not make the log unreadable."""
    import numpy as np
    path = tmp_path / "checks.csv"
    with CheckLogWriter(path, 1) as w:
        w.point("r", "t", 0, "marker", [1.0], [1, 2, 3], [1, 2, 3], 0.0, 0.3, True, "", np.full((3, 3), np.nan))
        w.point("r", "t", 1, "marker", [1.0], [1, 2, 3], [1, 2, 3], 0.0, 0.3, True, "", np.zeros((3, 3)))
        w.point("r", "t", 2, "marker", [1.0], [1, 2, 3], [1, 2, 3], 0.0, 0.3, True, "", np.diag([1e-5, -1e-5, 1e-5]))
    assert [p.covariance for p in read_check_log(path).checks[0].points] == [None, None, None]


def test_log_without_the_tool_column_is_read_and_rewritten_in_the_present_layout_to_append(tmp_path):
    path = tmp_path / "checks.csv"
    path.write_text(TAG + "\n" + ",".join(header_columns(1, tool=False)) + "\n"
                    "a,2025-01-01T10:00:00+00:00,point,3,marker,12.5,1,2,3,1,2,3.5,0.5,0.9,1\n"
                    "a,2025-01-01T10:00:09+00:00,overall,,,,,,,,,,0.5,0.8,1\n")
    log = read_check_log(path)
    assert not log.tool_column and log.checks[0].tool == "" and log.checks[0].points[0].pose == 3
    with CheckLogWriter(path, 1) as w:
        w.point("b", "t", 0, "marker", [1.0], [1, 2, 3], [1, 2, 3], 0.0, 0.3, True, "gripper")
    log = read_check_log(path)
    assert log.tool_column and log.covariance_columns
    assert [c.run for c in log.checks] == ["a", "b"] and log.checks[1].points[0].tool == "gripper"
    (old,) = log.checks[0].points
    assert old.pose == 3 and old.predicted.tolist() == [1, 2, 3.5] and old.tool == "" and old.covariance is None
    assert log.checks[0].rms_limit_mm == 0.8 and log.checks[0].within
    assert path.read_text().splitlines()[1] == ",".join(header_columns(1))


def test_cut_off_last_row_is_dropped_and_repaired_on_append(tmp_path):
    path = tmp_path / "checks.csv"
    write_two(path)
    with open(path, "a") as f:
        f.write("r2,t,point,0,marker,1.0,")
    assert len(read_check_log(path).checks) == 1
    with CheckLogWriter(path, 2) as w:
        w.point("r2", "t", 0, "marker", [1.0, 2.0], [1, 2, 3], [1, 2, 3], 0.0, 0.3, True)
    log = read_check_log(path)
    assert [len(c.points) for c in log.checks] == [2, 1]


@pytest.mark.parametrize("old, new, field", [
    (",0.3000,1,,,,,,,\n", ",0.3000,yes,,,,,,,\n", "within"),
    (",0.3000,1,,,,,,,\n", ",abc,1,,,,,,,\n", "limit_mm"),
    (",point,0,", ",dot,0,", "kind"),
    (",point,0,", ",point,zero,", "pose"),
])
def test_bad_values_name_file_line_and_column(tmp_path, old, new, field):
    path = tmp_path / "checks.csv"
    write_two(path)
    path.write_text(path.read_text().replace(old, new, 1))
    with pytest.raises(RoboCalError) as err:
        read_check_log(path)
    assert err.value.field == field and str(path) in str(err.value) and "line" in str(err.value)


def test_not_a_check_log(tmp_path):
    path = tmp_path / "m.csv"
    path.write_text("pose,q1\n0,1\n")
    with pytest.raises(RoboCalError, match="not a RoboCal check log"):
        read_check_log(path)


def test_other_robot_refused(tmp_path):
    path = tmp_path / "checks.csv"
    write_two(path)
    with pytest.raises(RoboCalError, match="2 joints"):
        CheckLogWriter(path, 6)
