"""The report's compensation section: before/after accuracy measured on the robot from the
project's accuracy_map.json, where it was measured, the largest joint corrections (checked
against the joints in the file), the figure's arrays, the files written; a missing map is not
done, a broken one is named."""
from __future__ import annotations

import json
import re

import numpy as np
import pytest

from core.compensation.accuracy_map import run_accuracy_map
from core.compensation.accuracy_map_file import write_accuracy_map
from core.compensation.workspace_grid import workspace_grid
from core.identification.solver import identify
from core.project import create_project
from core.report.build import build_report
from core.virtual_lab.ideal_measurements import ideal_lab_measurements, ideal_measure


@pytest.fixture(scope="module")
def measured(tmp_path_factory, built_lab):
    lab = built_lab(seed=0, noise=0.5)
    meas = ideal_lab_measurements(lab, 50, sigma_mm=0.05, seed=4)
    model = identify(lab.nominal_robot, meas).model
    grid = workspace_grid(model, meas.Q, count=10, keep=lambda Q: lab.visibility(Q).visible)
    amap = run_accuracy_map(lab.nominal_robot, model, grid, ideal_measure(lab, sigma_mm=0.02, seed=1),
                            measured_by="virtual lab, the true marker position")
    return lab, model, amap


def section(report):
    return next(s for s in report.sections if s.title == "Compensation")


def test_section_from_the_saved_map(measured, tmp_path):
    lab, model, amap = measured
    project = create_project(tmp_path / "p")
    write_accuracy_map(project.folder / "accuracy_map.json", amap, model)
    (project.folder / "corrected_program.csv").write_text("pose,q1,q2,q3,q4,q5,q6\n0,0,0,0,0,0,0\n")
    sec = section(build_report(project, robot=lab.nominal_robot))
    assert sec.done
    text = " ".join(b for b in sec.blocks if isinstance(b, str))
    assert "virtual lab, the true marker position" in text
    assert f"RMS {amap.rms_before_mm:.3f} mm" in text and f"RMS <b>{amap.rms_after_mm:.3f} mm</b>" in text
    assert f"{amap.improvement:.1f}×" in text and "accuracy_map.json, corrected_program.csv" in text
    # the largest correction listed first is the largest joint change of any target, in degrees
    dq = np.abs(np.rad2deg(amap.q_after - amap.q_before))[amap.both].max()
    assert re.search(rf"<td[^>]* class=n>{dq:.3f}</td>", text)
    fig = sec.figures()[0]
    vectors, hist = fig.panels
    assert hist["series"][0]["values"] == pytest.approx(list(amap.errors_before))
    assert hist["series"][1]["values"] == pytest.approx(list(amap.errors_after))
    assert "mm" in vectors["xlabel"] and "mm" in hist["xlabel"] and len(vectors["series"]) == 3


def test_missing_and_broken_maps(tmp_path, measured):
    lab, model, amap = measured
    project = create_project(tmp_path / "p")
    sec = section(build_report(project, robot=lab.nominal_robot))
    assert not sec.done and "no accuracy_map.json" in sec.blocks[0]
    path = write_accuracy_map(project.folder / "accuracy_map.json", amap, model)
    data = json.loads(path.read_text())
    data["points"][0]["target_mm"] = [1, 2]
    path.write_text(json.dumps(data))
    report = build_report(project, robot=lab.nominal_robot)
    assert not section(report).done and any("points[0].target_mm" in p for p in report.problems)
