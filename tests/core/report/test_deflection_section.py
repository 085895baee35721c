"""The report's deflection part of the identification section: a calibration with deflection
terms gives the verdict, the payload and the δq2/δq3 figure (its arrays checked against the
model); a rigid calibration gives one line; none considered and no payload give nothing."""
from __future__ import annotations

import numpy as np
import pytest

from core.identification.solver import identify, write_calibrated_model
from core.measurement.file import write_measurements
from core.project import create_project, save_robot
from core.report.build import build_report
from core.report.compliance import FIGURE
from core.robot.file import read_robot
from core.virtual_lab.ideal_measurements import ideal_lab_measurements


@pytest.fixture(scope="module")
def lab_data(built_lab):
    lab = built_lab(seed=0, noise=0.5, deflection=True)
    return lab, ideal_lab_measurements(lab, 40, sigma_mm=0.02, seed=4)


def project_with(folder, lab, meas, **identify_options):
    project = create_project(folder)
    save_robot(project, lab.nominal_robot, "virtual lab")
    write_measurements(meas, project.path("measurements"))
    write_calibrated_model(identify(lab.nominal_robot, meas, **identify_options), project.path("calibrated"))
    return project


def identification(project, robot):
    return next(s for s in build_report(project, robot=robot).sections if s.title == "Identification")


def texts(section) -> str:
    return " ".join(b for b in section.blocks if isinstance(b, str))


def test_terms_give_the_verdict_the_payload_and_the_corrections_per_pose(lab_data, tmp_path):
    lab, meas = lab_data
    project = project_with(tmp_path / "p", lab, meas, compliance="on", payload_kg=2.5)
    model = read_robot(project.path("calibrated"))
    assert model.compliance is not None and not model.compliance.is_zero
    section = identification(project, lab.nominal_robot)
    text = texts(section)
    verdict = model.calibration["statistics"]["compliance"]["verdict"]
    assert "<h3>Deflection under the arm's weight</h3>" in text and verdict in text
    assert "Payload during calibration: 2.5 kg — the deflection terms hold for this payload" in text
    fig = next(f for f in section.figures() if f.key == FIGURE)
    assert fig.unavailable is None
    by_pose, by_q2 = fig.panels
    ids = [int(p) for p in meas.pose_ids]
    first = [int(np.flatnonzero(meas.pose == p)[0]) for p in ids]
    dq = np.rad2deg(model.compliance.deflection(meas.Q[first]))
    assert by_pose["series"][0]["x"] == ids
    assert by_pose["series"][0]["y"] == pytest.approx(dq[:, 1]) and by_pose["series"][1]["y"] == pytest.approx(dq[:, 2])
    assert "(deg)" in by_pose["ylabel"] and by_q2["xlabel"] == "q2 (deg)"
    assert sorted(by_q2["series"][0]["x"]) == pytest.approx(np.sort(np.rad2deg(meas.Q[first, 1])))
    # the lab's arm bends by a few hundredths of a degree: the corrections are not all zero
    assert np.abs(dq[:, 1]).max() > 1e-3


def test_a_rigid_calibration_says_it_in_one_line(lab_data, tmp_path):
    lab, meas = lab_data
    project = project_with(tmp_path / "p", lab, meas)
    section = identification(project, lab.nominal_robot)
    assert all(f.key != FIGURE for f in section.figures())
    assert "Deflection under the arm" not in texts(section)
    project = project_with(tmp_path / "q", lab, meas, payload_kg=1.0)
    lines = [b for b in identification(project, lab.nominal_robot).blocks
             if isinstance(b, str) and "Deflection under the arm" in b]
    assert lines == ["<p><b>Deflection under the arm's weight:</b> Geometry only: deflection terms not asked for. "
                     "Payload during calibration: 1 kg.</p>"]
