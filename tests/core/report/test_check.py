"""The report's Check section from a project's own files: the control charts from the check log
(a check within limits, then one after the base moved), the diagnosis of the last check naming the
change, the re-identification history once it was re-identified, the tools and a fixture file."""
from __future__ import annotations

import numpy as np
import pytest

from core.measurement.file import Measurements
from core.monitoring.check import predict_points, run_check
from core.monitoring.diagnosis import diagnose
from core.monitoring.reidentify import reidentify, write_reidentified
from core.monitoring.uncertainty import calibration_uncertainty
from core.project import open_project
from core.report import build_report, render_html
from core.report.check import LOG_FILE
from core.robot.file import read_robot
from tests.core.report.sample_project import make_project


@pytest.fixture(scope="module")
def checked(tmp_path_factory):
    """The sample project checked twice: as calibrated (within), then with every point 2 mm off
    along x of the measurement frame (the robot base moved)."""
    project, _ = make_project(tmp_path_factory.mktemp("check") / "project")
    path = project.path("calibrated")
    model = read_robot(path)
    unc = calibration_uncertainty(model, source=path)
    rng = np.random.default_rng(3)
    Q = model.q_from_file(rng.uniform(-40.0, 40.0, (8, model.dof)))
    shift = np.zeros(3)

    def measure(q):
        return predict_points(model, q[None, :], ["marker"])[0] + shift + rng.normal(0, unc.sigma_mm, 3)

    log = project.folder / LOG_FILE
    first = run_check(model, unc, Q, measure, log=log)
    shift[0] = 2.0
    second = run_check(model, unc, Q, measure, log=log)
    return project, model, unc, first, second


def section(project):
    report = build_report(open_project(project.folder))
    return report, next(s for s in report.sections if s.title == "Check")


def test_the_control_charts_and_the_diagnosis_of_the_last_check(checked):
    project, model, unc, first, second = checked
    assert first.within and not second.within
    report, check = section(project)
    assert check.done and report.problems == []
    html = render_html(report)
    assert "2 checks in checks.csv (2 finished, 1 out of limits)" in html
    chart = next(f for f in check.figures() if f.key == "check_control")
    overall, points = chart.panels
    assert [s["name"] for s in overall["series"]] == ["RMS error", "limit", "beyond the limit"]
    np.testing.assert_allclose(overall["series"][0]["y"], [first.rms_mm, second.rms_mm], atol=1e-4)   # the log keeps 0.1 µm
    assert overall["series"][2]["x"] == [2.0]
    assert points["hlines"] == [(1.0, "limit")]
    beyond = next(s for s in points["series"] if s["name"] == "beyond its limit")
    assert set(beyond["x"]) == {2.0} and min(beyond["y"]) > 1.0
    expected = diagnose(model, unc, second).text
    assert "base" in expected.lower()
    assert f"Diagnosis of the last check</h3><p><b>{expected}" in html.replace("&#x27;", "'")
    assert "Re-identifications</h3><p>None" in html
    x, y, z = model.targets["marker"]
    assert f"<td>marker</td><td>{x:.3f}, {y:.3f}, {z:.3f}</td><td>yes</td><td>—</td>" in html
    assert "No fixture located" in html


def test_a_reidentification_is_listed_with_its_history(checked, tmp_path):
    project, model, unc, _, second = checked
    diagnosis = diagnose(model, unc, second)
    Q = np.array([p.Q for p in second.points])
    meas = Measurements(pose=np.arange(len(Q)), target=["marker"] * len(Q), q_file=model.q_to_file(Q),
                        xyz=np.array([p.measured for p in second.points]), Q=Q)
    re = reidentify(model, unc, diagnosis.parameters, meas, reason=diagnosis.text, previous="calibrated-old.json")
    write_reidentified(re, project.path("calibrated"))
    report, check = section(project)
    html = render_html(report)
    assert "re-identification (below); its diagnosis is the reason recorded there" in html
    entry = read_robot(project.path("calibrated")).calibration["history"][-1]
    assert entry["reason"] == diagnosis.text and entry["changed"]
    assert ", ".join(entry["changed"]) in html and "calibrated-old.json" in html


def test_a_located_fixture_is_listed(checked, tmp_path):
    from core.fixtures.file import write_fixture_pose
    from core.fixtures.frame import fit_fixture_frame

    project = checked[0]
    nominal = np.array([[0.0, 0, 0], [200, 0, 0], [0, 150, 0], [200, 150, 0]])
    measured = nominal + np.array([400.0, -50.0, 20.0])          # shifted, not turned
    frame = fit_fixture_frame(measured, nominal, [np.eye(3) * 0.01] * 4, names=list("ABCD"))
    write_fixture_pose(project.folder / "fixture_pose.json", frame, name="vise")
    html = render_html(section(project)[0])
    assert "“vise” located in the robot's base frame" in html
    assert "400.000 ± " in html and "-50.000 ± " in html and "<td>A, B, C, D</td>" in html
