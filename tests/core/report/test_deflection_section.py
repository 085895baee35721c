"""The report's deflection part of the identification section: a calibration with deflection
terms gives the verdict, the payload and the figure of δq2/δq3 and of the tool point's displacement
(its arrays checked against the model); a rigid calibration gives one line; none considered and no payload give nothing."""
from __future__ import annotations

import numpy as np
import pytest

from core.identification.file import write_calibrated_model
from core.identification.solver import identify
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
    by_pose, by_q2, moved = fig.panels
    ids = [int(p) for p in meas.pose_ids]
    first = [int(np.flatnonzero(meas.pose == p)[0]) for p in ids]
    dq = np.rad2deg(model.compliance.deflection(meas.Q[first]))
    assert by_pose["series"][0]["x"] == ids
    assert by_pose["series"][0]["y"] == pytest.approx(dq[:, 1]) and by_pose["series"][1]["y"] == pytest.approx(dq[:, 2])
    assert "(deg)" in by_pose["ylabel"] and by_q2["xlabel"] == "q2 (deg)"
    assert sorted(by_q2["series"][0]["x"]) == pytest.approx(np.sort(np.rad2deg(meas.Q[first, 1])))
    # the lab's arm bends by a few hundredths of a degree: the corrections are not all zero
    assert np.abs(dq[:, 1]).max() > 1e-3
    # the tool point's displacement: the rigid arm at the deflected joint values q + δq against q
    rigid = model.copy()
    rigid.compliance = None
    Q = meas.Q[first]
    bent = np.array([rigid.target_position(q, t) for q, t in zip(Q + model.compliance.deflection(Q),
                                                                  [meas.target[i] for i in first])])
    straight = np.array([rigid.target_position(q, meas.target[i]) for q, i in zip(Q, first)])
    delta = bent - straight
    down = model.base[:3, :3] @ np.array([0.0, 0.0, -1.0])
    assert moved["xlabel"] == "pose" and moved["ylabel"] == "displacement (mm)"
    assert [s["name"] for s in moved["series"]] == ["length |Δp| (mm)", "along gravity, down (mm)"]
    assert moved["series"][0]["x"] == ids
    assert moved["series"][0]["y"] == pytest.approx(np.linalg.norm(delta, axis=1), abs=1e-9)
    assert moved["series"][1]["y"] == pytest.approx(delta @ down, abs=1e-9)
    assert np.linalg.norm(delta, axis=1).max() > 0.01


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
