"""`robocal report`: a project with steps not done, a folder the command-line chain wrote (with the
student's name and course), another suffix and a missing folder refused. The report's drawing and
its writers: tests/app/report/test_render.py."""
from __future__ import annotations

import re

import pytest

from app.cli import main
from core.project import create_project
from tests.app.report.pdf_files import HAVE_POPPLER, pdf_text


@pytest.mark.skipif(not HAVE_POPPLER, reason="poppler-utils (pdftotext, pdfinfo) not installed")
def test_cli_report_of_a_project_with_steps_not_done(qapp, tmp_path, capsys):
    folder = create_project(tmp_path / "fresh").folder
    (folder / "stereo.yaml").write_text("not: [an, opencv, file\n")
    code = main(["report", str(folder), "--out", str(tmp_path / "r.pdf"), "--out", str(tmp_path / "r.html")])
    assert code == 0, capsys.readouterr().err
    text = pdf_text(tmp_path / "r.pdf")
    assert "Not done: Stereo calibration, Marker, Pose sequence, Measurements, Identification" in " ".join(
        text.split())
    assert "stereo.yaml cannot be read" in text
    assert "Not done (no calibrated.json" in (tmp_path / "r.html").read_text()


def test_cli_refuses_another_suffix_and_a_missing_folder(qapp, tmp_path, capsys):
    folder = create_project(tmp_path / "p").folder
    assert main(["report", str(folder), "--out", str(tmp_path / "r.docx")]) == 2
    assert "--out must end in .html or .pdf" in capsys.readouterr().err
    assert main(["report", str(tmp_path / "nowhere"), "--out", str(tmp_path / "r.pdf")]) == 2
    assert not (tmp_path / "r.pdf").exists()


def test_cli_report_of_a_command_line_folder_with_author_and_course(qapp, tmp_path, capsys):
    """A folder the command-line chain wrote (a dataset's truth.json, measurements.csv,
    calibrated.json, no project.json): its report, with the student's name and course."""
    import json as _json

    from core.identification.file import write_calibrated_model
    from core.identification.solver import identify
    from core.robot.file import robot_to_dict
    from core.virtual_lab.ideal_measurements import ideal_lab_measurements, write_ideal_measurements
    from core.virtual_lab.lab import VirtualLab

    lab = VirtualLab.create(seed=5)
    folder = tmp_path / "lab"
    folder.mkdir()
    meas = ideal_lab_measurements(lab, 30, sigma_mm=0.05, seed=1)
    write_ideal_measurements(meas, folder / "measurements.csv")
    write_calibrated_model(identify(lab.nominal_robot, meas), folder / "calibrated.json")
    (folder / "truth.json").write_text(_json.dumps({"format": "robocal.truth/1", "seed": 5,
                                                    "nominal_robot": robot_to_dict(lab.nominal_robot)}))
    out = tmp_path / "hand-in.html"
    code = main(["report", str(folder), "--out", str(out), "--author", "Ana Student", "--course", "Robotics 2"])
    assert code == 0, capsys.readouterr().err
    text = " ".join(re.sub(r"<[^>]+>", " ", out.read_text()).split())
    assert "Student / operator Ana Student Course Robotics 2" in text and "Cell the virtual lab" in text
    assert "Educational 6R" in text
    # the front page's RMS against the true robot, nominal and calibrated model
    before, after = (re.search(rf"true robot at \d+ fresh poses \(virtual lab\), {m} model [\d.]+ ([\d.]+)", text).group(1)
                     for m in ("nominal", "calibrated"))
    assert float(after) < 0.1 < float(before)                  # the lab of seed 5, not of seed 0
    empty = tmp_path / "empty"
    empty.mkdir()
    assert main(["report", str(empty), "--out", str(tmp_path / "e.html")]) == 1
    assert "no results of the command line" in capsys.readouterr().err
