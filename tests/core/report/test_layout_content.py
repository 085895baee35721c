"""What a report handed in must hold: the title block (student or operator, course, robot and its
serial number, date), the front page's before/after accuracy on the held-out poses, the fitted
poses' mean and max before calibration, parameters that the data cannot separate said in words
and never both listed as identified, and no empty placeholders."""
from __future__ import annotations

import re

import numpy as np
import pytest

from core.identification.fit import error_stats, register_base
from core.measurement.file import read_measurements
from core.project import open_project
from core.report import build_report, render_html
from core.report.document import parameter_name
from core.report.identification import NOT_SEPARABLE, not_separable
from core.robot.file import read_robot
from tests.core.report.sample_project import make_project


@pytest.fixture(scope="module")
def sample(tmp_path_factory):
    return make_project(tmp_path_factory.mktemp("layout") / "project")


def plain(html: str) -> str:
    return " ".join(re.sub(r"<[^>]+>", " ", html).replace("&gt;", ">").split())


def test_the_title_block_names_student_course_robot_serial_and_date(sample):
    project, result = sample
    report = build_report(open_project(project.folder), author="Ana Student", course="Robotics 2",
                          serial="RCS6-0421", date="2026-11-27 08:00 UTC")
    header = plain(report.header)
    for field in ("Student / operator Ana Student", "Course Robotics 2", f"Robot {result.model.name}",
                  "Serial number RCS6-0421", "Date 2026-11-27 08:00 UTC", "Cell the virtual lab"):
        assert field in header, field
    # a field not given is left out, not shown empty
    bare = plain(build_report(open_project(project.folder), date="2026-11-27").header)
    assert "Student" not in bare and "Serial number" not in bare and "Date 2026-11-27" in bare


def test_the_front_page_gives_mean_rms_and_max_before_and_after_on_held_out_poses(sample):
    project, result = sample
    summary = plain(build_report(open_project(project.folder)).summary)
    v = result.validation
    n = len(v.test_poses)
    for model, stats in (("nominal", v.before), ("calibrated", v.after)):
        row = re.search(rf"{n} held-out poses, {model} model ([\d.]+) ([\d.]+) ([\d.]+)", summary)
        assert row, summary
        assert [float(x) for x in row.groups()] == pytest.approx(
            [stats.mean_mm, stats.rms_mm, stats.max_mm], abs=6e-4)


def test_the_fitted_poses_before_calibration_have_mean_and_max(sample):
    project, result = sample
    report = build_report(open_project(project.folder))
    text = plain(render_html(report))
    row = re.search(r"before \(nominal model, base registered\) (\S+) (\S+) (\S+) (\d+)", text)
    assert row and "—" not in row.groups(), text[:2000]
    # the nominal model with its base registered on the fitted poses, on the fitted poses' points
    robot = read_robot(project.path("robot"))
    meas = read_measurements(project.path("measurements"), robot)
    fitted = [p for p in meas.pose_ids if p not in set(result.validation.test_poses)]
    stats = error_stats(register_base(robot, meas.select_poses(fitted)), meas.select_poses(fitted))
    assert [float(x) for x in row.groups()[:3]] == pytest.approx([stats.mean_mm, stats.rms_mm, stats.max_mm],
                                                                 abs=6e-4)
    assert int(row.group(4)) == stats.n
    # the RMS agrees with the one the identification saved
    assert stats.rms_mm == pytest.approx(result.before.rms_mm, rel=1e-6)


def test_parameters_not_separable_are_said_and_not_listed_as_identified(sample):
    project, result = sample
    report = build_report(open_project(project.folder))
    c = np.asarray(result.correlation)
    names = list(result.estimated)
    expected = {(a, b) for i, a in enumerate(names) for j, b in enumerate(names)
                if j < i and abs(c[i, j]) > NOT_SEPARABLE}
    together = not_separable(names, np.round(c, 3))
    assert {(a, b) for a, b, _ in together} == expected
    assert expected, "the sample's fit has no inseparable pair: the test would prove nothing"
    html = render_html(report)
    text = plain(html)
    for a, b, r in together:
        assert f"{parameter_name(a)} and {parameter_name(b)} are not separable (r = {r:+.3f})" in text
        for name, other in ((a, b), (b, a)):       # the parameter table's status cell of each
            row = re.search(rf"<td[^>]*>{re.escape(parameter_name(name))}</td>(?:<td[^>]*>[^<]*</td>){{3}}<td[^>]*>([^<]*)</td>",
                            html)
            assert row and row.group(1) == f"only with {parameter_name(other)}", (name, row and row.group(1))
    assert "see Identification" in plain(report.summary)


def test_a_pair_just_below_the_threshold_is_separable():
    m = np.array([[1.0, 0.99], [0.99, 1.0]])
    assert not_separable(["a", "b"], m) == []
    m[0, 1] = m[1, 0] = -0.995
    assert not_separable(["a", "b"], m) == [("b", "a", -0.995)]


def test_no_placeholder_says_not_available(sample, tmp_path):
    project, _ = sample
    text = render_html(build_report(open_project(project.folder)))
    assert "not available" not in text.lower()
    # a project with only a robot: every missing figure is one sentence saying why, or left out
    import shutil
    copy = shutil.copytree(project.folder, tmp_path / "copy")
    for name in ("measurements.csv", "stereo.json"):
        (copy / name).unlink()
    text = render_html(build_report(open_project(copy)))
    assert "not available" not in text.lower()
    # two figures missing for one reason: one sentence names both
    assert ("No figures “reprojection error per pair”, “corner residuals”: the project has stereo.yaml but not "
            "its details") in text


def test_greek_parameter_names():
    assert [parameter_name(n) for n in ("J5.theta", "J2.alpha", "J2.beta", "J4.d", "base.rx")] == \
        ["J5.θ", "J2.α", "J2.β", "J4.d", "base.rx"]
