"""The report as data: every section and figure a full project allows, steps not done listed,
unreadable files named (never a crash), the summary's numbers."""
from __future__ import annotations

import json

import numpy as np
import pytest

from core.project import create_project, open_project
from core.robot.file import read_robot
from core.stereo.file import read_stereo_yaml
from core.report import build_report, calibration_report, render_html
from core.report.document import parameter_name
from tests.core.report.sample_project import COVERAGE, CROSS_VALIDATION, THRESHOLD_PX, make_project

STEPS = ["Stereo calibration", "Marker", "Pose sequence", "Measurements", "Identification", "Check", "Compensation"]
DRAWN = ["stereo_pairs", "stereo_residuals", "stereo_coverage", "stereo_cross_validation", "poses_joints", "poses_index", "poses_views", "measurement_points",
         "identification_per_pose", "identification_histograms", "identification_convergence",
         "identification_correlation"]


@pytest.fixture(scope="module")
def sample(tmp_path_factory):
    return make_project(tmp_path_factory.mktemp("report") / "project")


def figures(report) -> dict:
    return {f.key: f for f in report.figures()}


def test_a_full_project_has_every_section_and_figure(sample):
    project, result = sample
    report = build_report(open_project(project.folder))
    assert [s.title for s in report.sections] == STEPS
    assert report.not_done() == ["Marker", "Check", "Compensation"] and report.problems == []
    figs = figures(report)
    for key in DRAWN:
        assert key in figs and figs[key].unavailable is None and figs[key].panels, key


def test_figure_data_are_the_project_numbers(sample):
    project, result = sample
    figs = figures(build_report(open_project(project.folder)))
    pairs = figs["stereo_pairs"].panels[0]
    assert pairs["hlines"][0][0] == THRESHOLD_PX and "px" in pairs["ylabel"]
    assert pairs["series"][0]["y"][-1] == pytest.approx(0.9)
    per_pose = {s["name"]: s for s in figs["identification_per_pose"].panels[0]["series"]}
    held = per_pose["after, held-out pose"]
    assert sorted(int(x) for x in held["x"]) == sorted(result.validation.test_poses)
    # the held-out errors drawn are those the identification reported (files hold 1e-6 mm / deg digits)
    def rms(s):
        return float(np.sqrt(np.mean(np.square(s["y"]))))
    assert rms(held) == pytest.approx(result.validation.after.rms_mm, rel=1e-4)
    assert rms(per_pose["before, held-out pose"]) == pytest.approx(result.validation.before.rms_mm, rel=1e-4)
    assert "mm" in figs["identification_per_pose"].panels[0]["ylabel"]
    coverage = figs["stereo_coverage"].panels[0]
    assert coverage["series"][0]["y"] == [COVERAGE[k] for k in ("X", "Y", "size", "skew")]
    assert "show the board nearer and farther" in figs["stereo_coverage"].caption
    cv = figs["stereo_cross_validation"].panels[0]
    assert cv["series"][0]["y"][0] == CROSS_VALIDATION["rms_observed_px"] and "px" in cv["ylabel"]
    corr = figs["identification_correlation"]
    m = corr.panels[0]["matrix"]
    assert m.shape == (len(result.estimated),) * 2
    assert np.allclose(m, result.correlation, atol=6e-4)               # saved to 3 digits
    # the rows and columns are named by the parameters (theta, alpha, beta as θ, α, β)
    assert corr.panels[0]["labels"] == [parameter_name(n) for n in result.estimated]
    n_iter = len(result.costs)
    assert len(figs["identification_convergence"].panels[0]["series"][0]["y"]) == n_iter


def test_summary_numbers_and_verdict(sample):
    project, result = sample
    report = build_report(open_project(project.folder))
    v = result.validation
    factor = v.before.rms_mm / v.after.rms_mm
    assert f"{v.after.rms_mm:.3f}" in report.summary and f"{factor:.1f}×" in report.summary
    assert result.model.name in report.header
    assert "0.310 px RMS" in report.summary and "more accurate" in report.summary


def test_an_empty_project_lists_every_step_as_not_done(tmp_path):
    project = create_project(tmp_path / "empty")
    report = build_report(project)
    assert report.not_done() == STEPS
    assert "Not calibrated yet" in report.summary and "Not done:" in report.summary
    text = render_html(report)
    assert text.count("Not done (no ") == len(STEPS)


@pytest.mark.parametrize("name, content, needle", [
    ("calibrated.json", '{"format": "robocal.robot/1", "name": "x", "joi', "calibrated.json"),
    ("stereo.yaml", "not: [an, opencv, file\n", "stereo.yaml"),
    ("stereo.json", '{"views": [{"pair": "one"}]}', "stereo.json"),
    ("measurements.csv", "pose,target\n0,marker\n", "measurements.csv"),
])
def test_an_unreadable_file_is_named_and_the_rest_is_reported(sample, tmp_path, name, content, needle):
    import shutil
    project, _ = sample
    copy = shutil.copytree(project.folder, tmp_path / "copy")
    (copy / name).write_text(content)
    report = build_report(open_project(copy))
    assert any(p.startswith(needle) for p in report.problems), report.problems
    assert needle in report.summary and "could not be read" in report.summary
    assert f"{needle} cannot be read" in render_html(report)
    assert len(report.sections) == len(STEPS)


def test_calibration_report_is_html_naming_undrawn_figures(sample):
    project, _ = sample
    text = calibration_report(open_project(project.folder))
    assert text.startswith("<!DOCTYPE html>") and "could not be drawn" in text


def test_the_saved_validation_records_its_poses(sample):
    project, result = sample
    saved = json.loads(project.path("calibrated").read_text())["calibration"]["statistics"]
    assert saved["validation"]["test_poses"] == result.validation.test_poses
    assert saved["cost_per_iteration"] == pytest.approx(result.costs)


def test_a_calibrated_json_without_correlation_says_why(sample, tmp_path):
    import shutil
    project, _ = sample
    copy = shutil.copytree(project.folder, tmp_path / "copy")
    data = json.loads((copy / "calibrated.json").read_text())
    del data["calibration"]["correlation"]
    (copy / "calibrated.json").write_text(json.dumps(data))
    report = build_report(open_project(copy))
    assert "identification_correlation" not in figures(report)
    text = render_html(report)
    assert "correlation matrix is not shown: calibrated.json was written by an older version" in text


def test_the_pose_views_place_the_cameras_through_the_calibrated_base(sample):
    project, result = sample
    report = build_report(open_project(project.folder))
    top = figures(report)["poses_views"].panels[0]
    cams = next(s for s in top["series"] if s["name"].startswith("cameras"))
    stereo = read_stereo_yaml(project.path("stereo"))
    robot = read_robot(project.path("robot"))
    left = robot.base @ np.linalg.inv(result.model.base)          # the left camera's pose in the world frame
    assert cams["x"][0] == pytest.approx(left[0, 3], abs=1e-6) and cams["y"][0] == pytest.approx(left[1, 3], abs=1e-6)
    side = figures(report)["poses_views"].panels[1]
    cams_side = next(s for s in side["series"] if s["name"].startswith("cameras"))
    gap = np.linalg.norm([cams["x"][1] - cams["x"][0], cams["y"][1] - cams["y"][0],
                          cams_side["y"][1] - cams_side["y"][0]])
    assert gap == pytest.approx(stereo.baseline_mm, rel=1e-9)
