"""The Export page: one button per export with its target path, Export all into project/export,
stereo files only once stereo.yaml exists, the report, clear messages, the autopilot.
Also core.report and core.virtual_lab.ideal_measurements, which only this page and the Identification
page use."""
from __future__ import annotations

import re
import xml.etree.ElementTree as ET

import cv2
import numpy as np
import pytest
from PySide6.QtCore import Qt
from PySide6.QtWidgets import QFileDialog

from app.pages.export.page import ExportPage
from app.state import WizardState
from app.worker import TaskRunner
from core.stereo.board import Board
from core.identification.file import write_calibrated_model
from core.identification.solver import identify
from core.measurement.synthetic import is_synthetic, synthetic_description
from core.virtual_lab.ideal_measurements import write_ideal_measurements
from core.kinematics.identifiability import random_configurations
from core.robot.model import robot_path
from core.measurement.file import read_measurements, write_measurements
from core.identification.model_comparison import accuracy_against_truth
from core.project import open_project
from core.report import calibration_report
from core.robot.file import read_robot
from core.stereo.file import StereoFile, read_stereo_yaml, write_stereo_yaml
from core.virtual_lab.synthetic import perturbed_model, simulate_measurements

MODEL_FILES = ["calibrated.json", "calibrated.urdf", "calibrated_dh.csv"]


@pytest.fixture(scope="module")
def calibration():
    """(measurements, result, accuracy) of a quick synthetic identification."""
    robot = read_robot(robot_path("educational_6r"))
    true = perturbed_model(robot, 4)
    meas = simulate_measurements(true, 30, sigma_mm=0.05, rng=5)
    result = identify(robot, meas, holdout=0.25)
    accuracy = accuracy_against_truth(true, result.initial, result.model, random_configurations(robot, 50, seed=6))
    return meas, result, accuracy


@pytest.fixture
def page(qtbot, tmp_path):
    state, tasks = WizardState(), TaskRunner()
    state.new_project(tmp_path / "project")
    state.choose_preset("educational_6r")
    p = ExportPage(state, tasks)
    qtbot.addWidget(p)
    p.resize(900, 760)
    p.show()
    p.on_enter()
    yield p
    tasks.shutdown()
    state.close()


def give_result(page, calibration, measurements=True):
    meas, result, accuracy = calibration
    if measurements:
        write_measurements(meas, page.state.project.path("measurements"))
    page.state.set_identification(result, accuracy)
    return result


def export_report(page, qtbot) -> list:
    """The report row's export, which runs on a worker: the files written ([] on failure)."""
    got = []
    page.export("report", finished=got.append)
    qtbot.waitUntil(lambda: bool(got), timeout=60000)
    assert not page.task.busy
    return got[0]


def stereo_file() -> StereoFile:
    K = np.array([[800.0, 0, 320], [0, 800, 256], [0, 0, 1]])
    D = np.zeros(5)
    R, T = np.eye(3), np.array([-120.0, 0.0, 0.0])
    R1, R2, P1, P2, Q, *_ = cv2.stereoRectify(K, D.reshape(1, 5), K, D.reshape(1, 5), (640, 512), R,
                                             T.reshape(3, 1))
    E = np.array([[0, 0, 0], [0, 0, 120.0], [0, -120.0, 0]])
    F = np.linalg.inv(K).T @ E @ np.linalg.inv(K)
    return StereoFile((640, 512), K, D, K, D, R, T, E, F, R1, R2, P1, P2, Q, 0.21, 0.23, 0.31,
                      Board(9, 6, 25.0), {"epipolar_rms": 0.05})


def test_before_identification_only_the_report_is_available(page):
    folder = page.state.project.folder / "export"
    assert page.folder_edit.text() == str(folder)
    for key in ("calibrated", "dh-csv", "urdf"):
        assert "available after the Identification step" in page.row_text(key)
        assert not page.rows[key]["button"].isEnabled()
    assert "available after the Stereo calibration step" in page.row_text("stereo")
    assert str(folder / "report.html") in page.row_text("report")
    assert page.rows["report"]["button"].isEnabled() and not page.is_complete()
    assert page.export("urdf") == [] and not folder.exists()


def test_export_all_writes_every_available_file(page, calibration, qtbot):
    result = give_result(page, calibration)
    assert "from this session's identification" in page.row_text("urdf")
    qtbot.mouseClick(page.all_button, Qt.MouseButton.LeftButton)
    assert page.task.busy and not page.all_button.isEnabled()          # the report is written on a worker
    qtbot.waitUntil(lambda: "file(s) written" in page.status.text(), timeout=60000)
    assert not page.task.busy and page.all_button.isEnabled()
    folder = page.state.project.folder / "export"
    assert sorted(p.name for p in folder.iterdir()) == sorted(MODEL_FILES + ["report.html", "report.pdf"])
    assert page.is_complete()
    status = page.status.text()
    assert "5 file(s) written" in status and "Stereo camera files" in status and "Skipped" in status
    bar = page.task.progress_row().bar
    assert bar.value() == bar.maximum() and "report written" in bar.format()      # not left at "saving 95 %"

    model = read_robot(folder / "calibrated.json")
    assert model.calibration["statistics"]["rms_after_mm"] == pytest.approx(result.after.rms_mm)
    assert (folder / "calibrated_dh.csv").read_text().splitlines()[0].startswith("joint,type,theta_deg")
    root = ET.parse(folder / "calibrated.urdf").getroot()
    assert root.tag == "robot" and root.find("link[@name='marker']") is not None

    report = (folder / "report.html").read_text()
    for text in ("RoboCal calibration report", "condition number", "held-out poses",
                 "true robot", f"{result.after.rms_mm:.3f}", f"{result.validation.after.rms_mm:.3f}",
                 "Not done (no stereo.yaml", "30 poses"):
        assert text in report, text
    assert "✓ Exported" in page.row_text("report")


def test_calibrated_json_is_copied_from_the_project(page, calibration, tmp_path, qtbot):
    _, result, _ = calibration
    saved = write_calibrated_model(result, page.state.project.path("calibrated"))
    page.state.set_project(open_project(page.state.project.folder))   # a new session: no result in memory
    assert page.calibrated_source() == "file"
    assert "from the project's calibrated.json" in page.row_text("calibrated")
    written = page.export("calibrated")
    assert written[0].read_bytes() == saved.read_bytes()
    assert page.export("dh-csv") and page.export("urdf")
    report = export_report(page, qtbot)[0].read_text()
    assert "From calibrated.json" in report and "rank" in report


def test_stereo_files_once_stereo_yaml_exists(page, qtbot):
    sf = stereo_file()
    src = write_stereo_yaml(page.state.project.path("stereo"), sf)
    page.refresh()
    assert page.rows["stereo"]["button"].isEnabled()
    written = page.export("stereo")
    assert [p.name for p in written] == ["stereo.yaml", "left.yaml", "right.yaml"]
    assert written[0].read_bytes() == src.read_bytes()
    assert read_stereo_yaml(written[0]).rms_stereo == pytest.approx(0.31)
    left = written[1].read_text()
    assert "camera_matrix" in left and "image_width: 640" in left
    report = export_report(page, qtbot)[0].read_text()
    assert "reprojection error, stereo" in report and "0.310 px RMS" in report


def test_a_bad_stereo_yaml_is_a_clear_row_message(page, qtbot):
    page.state.project.path("stereo").write_text("not: [an, opencv, file\n")
    page.refresh()
    assert page.export("stereo") == []
    assert "✗" in page.row_text("stereo") and "stereo.yaml" in page.row_text("stereo")
    assert not (page.state.project.folder / "export" / "stereo.yaml").exists()
    assert "cannot be read" in export_report(page, qtbot)[0].read_text()


def test_export_into_a_chosen_folder(page, calibration, monkeypatch, tmp_path):
    give_result(page, calibration, measurements=False)
    monkeypatch.setattr(QFileDialog, "getExistingDirectory", lambda *a, **k: str(tmp_path / "elsewhere"))
    chosen = page.choose_folder()
    assert chosen == tmp_path / "elsewhere" and page.folder_edit.text() == str(chosen)
    assert str(tmp_path / "elsewhere" / "calibrated.urdf") in page.row_text("urdf")
    written = page.export("urdf")
    assert written == [tmp_path / "elsewhere" / "calibrated.urdf"]
    monkeypatch.setattr(QFileDialog, "getExistingDirectory", lambda *a, **k: "")
    assert page.choose_folder() is None and page.folder() == tmp_path / "elsewhere"


def test_an_unwritable_folder_gives_a_clear_message(page, calibration, tmp_path):
    give_result(page, calibration, measurements=False)
    blocker = tmp_path / "a-file"
    blocker.write_text("x")
    page.set_folder(blocker / "sub")
    assert page.export("calibrated") == []
    assert "cannot create the folder" in page.row_text("calibrated")
    assert page.status.text().startswith("✗") and not page.is_complete()


def test_autopilot_exports_everything_available(page, calibration, qtbot):
    give_result(page, calibration)
    done = []
    page.autopilot(lambda ok=True, message="": done.append((ok, message)))
    qtbot.waitUntil(lambda: bool(done), timeout=60000)
    assert done == [(True, "")]
    folder = page.state.project.folder / "export"
    assert sorted(p.name for p in folder.iterdir()) == sorted(MODEL_FILES + ["report.html", "report.pdf"])


def test_a_new_project_resets_the_page(page, calibration, tmp_path, qtbot):
    give_result(page, calibration)
    first = page.folder()
    page.export_all()
    assert page.is_complete() and page.task.busy                 # the report still being written
    page.state.new_project(tmp_path / "second")
    assert not page.is_complete() and not page.task.busy
    qtbot.waitUntil(lambda: not page.task.runner.busy, timeout=60000)
    assert not (first / "report.html").exists() and "report" not in page.exported
    assert page.folder_edit.text() == str(tmp_path / "second" / "export")
    assert "available after the Identification step" in page.row_text("urdf")


# -- core pieces used by the two pages ---------------------------------------------------------
def test_ideal_measurements_file_is_marked_synthetic(tmp_path, calibration):
    meas, _, _ = calibration
    path = write_ideal_measurements(meas, tmp_path / "measurements.csv", sigma_mm=0.05)
    assert is_synthetic(path) and "sigma = 0.05 mm" in synthetic_description(path)
    back = read_measurements(path)
    assert back.n_points == meas.n_points and np.allclose(back.xyz, meas.xyz, atol=1e-6)
    plain = write_measurements(meas, tmp_path / "real.csv")
    assert not is_synthetic(plain) and not is_synthetic(tmp_path / "missing.csv")


def test_report_of_an_empty_project(tmp_path):
    state = WizardState()
    try:
        project = state.new_project(tmp_path / "empty")
        text = calibration_report(project)
    finally:
        state.close()
    assert text.startswith("<!DOCTYPE html>") and "Not done (no calibrated.json" in text
    assert "Not done (no measurements.csv" in text


def test_report_counts_the_pose_sequence(page, qtbot):
    page.state.project.path("poses").write_text("pose,q1,q2,q3,q4,q5,q6\n0,1,2,3,4,5,6\n1,1,2,3,4,5,7\n")
    assert "2 poses in poses.csv" in export_report(page, qtbot)[0].read_text()
    page.state.project.path("poses").write_text("pose,q1\n0,x\n")
    assert "poses.csv cannot be read" in export_report(page, qtbot)[0].read_text()


def test_the_report_is_written_on_a_worker_with_progress_and_cancel(page, calibration, qtbot):
    give_result(page, calibration)
    folder = page.folder()
    folder.mkdir(parents=True)
    (folder / "report.html").write_text("previous report")
    got = []
    page.export("report", finished=got.append)
    row = page.task.progress_row()
    assert page.task.busy and not page.rows["report"]["button"].isEnabled() and "Writing" in page.row_text("report")
    qtbot.waitUntil(lambda: "drawing figure" in row.bar.format(), timeout=60000)   # figures one by one
    assert page.task.busy and row.cancel_button.isEnabled() and not got
    qtbot.mouseClick(row.cancel_button, Qt.MouseButton.LeftButton)
    qtbot.waitUntil(lambda: bool(got), timeout=60000)
    assert got == [[]] and not page.task.busy and "Cancelled" in page.row_text("report")
    assert sorted(p.name for p in folder.iterdir()) == ["report.html"]             # no temporary left
    assert (folder / "report.html").read_text() == "previous report"
    written = export_report(page, qtbot)
    assert [p.name for p in written] == ["report.html", "report.pdf"] and "✓ Exported" in page.row_text("report")
    assert "<img src='data:image/png;base64," in written[0].read_text()


def test_a_read_only_export_folder_is_one_clear_message(page, calibration, qtbot, tmp_path):
    from tests.app.report.test_render import read_only

    give_result(page, calibration)
    out = tmp_path / "out"
    out.mkdir()
    page.set_folder(out)
    with read_only(out):
        assert export_report(page, qtbot) == []
    assert f"✗ {out}: the folder is not writable" in page.row_text("report")
    assert page.status.text().startswith("✗ Report") and list(out.iterdir()) == []


def test_stereo_files_are_written_all_or_none(page):
    write_stereo_yaml(page.state.project.path("stereo"), stereo_file())
    folder = page.state.project.folder / "export"
    folder.mkdir()
    (folder / "stereo.yaml").write_text("previous export\n")
    (folder / "right.yaml").mkdir()                   # a folder in the way of one of the three files
    assert page.export("stereo") == []
    assert "✗" in page.row_text("stereo") and "right.yaml" in page.row_text("stereo")
    assert (folder / "stereo.yaml").read_text() == "previous export\n"
    assert not (folder / "left.yaml").exists()


def test_an_export_held_by_a_running_command_is_refused_on_its_row(page, calibration):
    """A robocal command writing the same file holds its output lock: the page writes nothing and
    says which process has it; once the command is done, the export works."""
    import os

    from core.locks import output_lock

    give_result(page, calibration)
    folder = page.state.project.folder / "export"
    folder.mkdir()
    (folder / "calibrated_dh.csv").write_text("previous\n")
    with output_lock(folder / "calibrated_dh.csv"):
        assert page.export("dh-csv") == []
    assert f"being written by process {os.getpid()}" in page.row_text("dh-csv")
    assert (folder / "calibrated_dh.csv").read_text() == "previous\n"
    assert [p.name for p in page.export("dh-csv")] == ["calibrated_dh.csv"]


def test_the_report_title_fields_go_into_the_report(page, calibration, qtbot):
    give_result(page, calibration)
    fields = page.report_title
    for key, text in (("author", "Ana Student"), ("course", "Robotics 2"), ("serial", "RCS6-0421")):
        qtbot.keyClicks(fields.edits[key], text)
    written = export_report(page, qtbot)
    html = next(p for p in written if p.suffix == ".html").read_text()
    text = " ".join(re.sub(r"<[^>]+>", " ", html).split())
    for field in ("Student / operator Ana Student", "Course Robotics 2", "Serial number RCS6-0421"):
        assert field in text, field
