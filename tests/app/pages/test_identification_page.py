"""The Identification page, driven end to end with pytest-qt: measurements (ideal virtual-lab
ones or a synthetic file), the worker thread, the table and plots, exports, Cancel, bad files,
and the autopilot."""
from __future__ import annotations

import numpy as np
import pytest
from PySide6.QtCore import Qt
from PySide6.QtWidgets import QFileDialog

from app.pages.identification.page import IdentificationPage
from app.pages.identification.source_panel import IDEAL_BUTTON_TEXT
from app.state import WizardState
from app.worker import TaskRunner
from core import project as projects
from core.measurement.synthetic import is_synthetic
from core.kinematics.identifiability import FIXED_BY_USER
from core.measurement.file import read_measurements, write_measurements
from core.robot.file import read_robot
from core.virtual_lab.robot_deflection import deflecting_robot
from core.virtual_lab.synthetic import perturbed_model, simulate_measurements


def make_page(qtbot, tmp_path, mode=projects.VIRTUAL_LAB):
    state, tasks = WizardState(), TaskRunner()
    state.new_project(tmp_path / f"project-{mode}", mode=mode)
    state.choose_preset("educational_6r")
    page = IdentificationPage(state, tasks)
    qtbot.addWidget(page)
    page.resize(900, 760)
    page.show()
    page.on_enter()
    return page


@pytest.fixture
def cleanup():
    pages = []
    yield pages
    for page in pages:
        page.task.runner.shutdown()
        page.state.close()


@pytest.fixture
def lab_page(qtbot, tmp_path, cleanup):
    page = make_page(qtbot, tmp_path)
    cleanup.append(page)
    return page


@pytest.fixture
def hw_page(qtbot, tmp_path, cleanup):
    """A hardware-mode project: no virtual lab, so no lab is built (fast)."""
    page = make_page(qtbot, tmp_path, projects.HARDWARE)
    cleanup.append(page)
    return page


def write_synthetic(page, n_poses=30, seed=1):
    robot = page.state.robot
    true = perturbed_model(robot, seed)
    meas = simulate_measurements(true, n_poses, sigma_mm=0.05, rng=seed + 1)
    return write_measurements(meas, page.measurements_path())


def wait_idle(qtbot, page, timeout=30000):
    qtbot.waitUntil(lambda: not page.task.busy and not page.task.runner.busy, timeout=timeout)


def identify(qtbot, page):
    assert page.start_identification(), page.status.text()
    wait_idle(qtbot, page)


# -- no measurements -------------------------------------------------------------------------
def test_without_measurements_the_page_says_what_to_do(lab_page, hw_page):
    for page in (lab_page, hw_page):
        text = page.source.source_label.text()
        assert "No measurements in this project" in text and "Measurement" in text
        assert not page.options.run_button.isEnabled() and not page.is_complete()
        assert not page.start_identification()
        assert "run the Measurement step" in page.status.text()
    assert lab_page.source.ideal_button.isVisible() and lab_page.source.ideal_button.text() == IDEAL_BUTTON_TEXT
    assert "synthetic" in lab_page.source.source_label.text()
    assert not hw_page.source.ideal_button.isVisible()                  # hardware: no teaching shortcut
    assert not hw_page.use_ideal_measurements()


# -- the whole step in the virtual lab ---------------------------------------------------------
def test_ideal_measurements_identify_and_export(lab_page, qtbot, monkeypatch, tmp_path):
    page = lab_page
    qtbot.mouseClick(page.source.ideal_button, Qt.MouseButton.LeftButton)
    wait_idle(qtbot, page)
    path = page.measurements_path()
    assert path.is_file() and is_synthetic(path)
    meas = read_measurements(path, page.state.robot)
    assert meas.n_poses == 50 and meas.target_names == ["marker"]
    assert "SYNTHETIC" in page.source.source_label.text() and "50 poses" in page.source.source_label.text()
    assert not page.source.ideal_button.isVisible() and page.options.run_button.isEnabled()

    with qtbot.waitSignal(page.completeChanged, timeout=30000):
        qtbot.mouseClick(page.options.run_button, Qt.MouseButton.LeftButton)
    wait_idle(qtbot, page)
    result = page.result
    assert result is not None and page.is_complete()
    assert page.state.identification is result
    assert result.after.rms_mm < 0.15 < 1.0 < result.before.rms_mm
    assert result.validation.method == "holdout" and result.validation.fraction == 0.25

    # the table: one row per parameter, the ones not estimated greyed and explained
    table = page.results.table
    assert table.rowCount() == len(result.parameters)
    for r, row in enumerate(result.parameters):
        assert table.cell_text(r, 0) == row.name
        assert table.is_greyed(r) == (not row.identifiable)
        if not row.identifiable:
            assert row.explanation and row.explanation in table.item(r, 0).toolTip()
            assert table.cell_text(r, 4) == "—"
        else:
            assert table.cell_text(r, 4).startswith("± ")
    assert any(table.is_greyed(r) for r in range(table.rowCount()))
    assert "Not estimated" in page.results.explanation.text()
    grey = next(r for r in range(table.rowCount()) if table.is_greyed(r))
    table.selectRow(grey)
    assert result.parameters[grey].explanation in page.results.explanation.text()

    # the plots have the result's data
    series = page.results.residuals.bars.series()
    assert len(series["pose"]) == result.n_poses
    assert np.allclose(series["before"], [p["error_mm"] for p in result.before.per_pose()])
    assert page.results.residuals.histogram.counts["before"].sum() == result.n_points
    assert page.results.residuals.histogram.counts["after"].sum() == result.n_points
    convergence = page.results.convergence
    assert len(convergence.x) >= 3 and convergence.y[0] > convergence.y[-1]
    assert page.results.convergence.getPlotItem().ctrl.logYCheck.isChecked()
    assert page.results.correlation.matrix.shape == (len(result.estimated),) * 2
    correlation = page.results.correlation
    assert correlation.hover_text(0, 1).startswith(f"{result.estimated[0]} (1) × {result.estimated[1]} (2)")
    page.results.residuals.set_log(False)
    bars = page.results.residuals.bars
    assert not bars.log and np.allclose(bars.series()["before"], series["before"])

    # validation figures and the accuracy against the lab's true robot
    text = page.results.validation_view.toPlainText()
    assert "held-out poses" in text and "true robot" in text
    accuracy = page.state.accuracy
    assert accuracy.calibrated.rms_mm < 0.2 * accuracy.nominal.rms_mm
    assert "against the true robot" in page.results.summary.text()

    # exports
    qtbot.mouseClick(page.save_button, Qt.MouseButton.LeftButton)
    saved = page.state.project.path("calibrated")
    model = read_robot(saved)
    assert model.calibration["statistics"]["rms_after_mm"] == pytest.approx(result.after.rms_mm)
    assert str(saved) in page.status.text()
    targets = iter([str(tmp_path / "out" / "dh.csv"), str(tmp_path / "out" / "robot.urdf")])
    monkeypatch.setattr(QFileDialog, "getSaveFileName", lambda *a, **k: (next(targets), ""))
    qtbot.mouseClick(page.csv_button, Qt.MouseButton.LeftButton)
    qtbot.mouseClick(page.urdf_button, Qt.MouseButton.LeftButton)
    assert (tmp_path / "out" / "dh.csv").read_text().startswith("joint,type,theta_deg")
    assert "<robot" in (tmp_path / "out" / "robot.urdf").read_text()
    monkeypatch.setattr(QFileDialog, "getSaveFileName", lambda *a, **k: ("", ""))
    assert page.export_file("urdf") is None                      # dialog cancelled: nothing written


def test_autopilot_generates_identifies_and_saves(lab_page, qtbot):
    done = []
    lab_page.autopilot(lambda ok=True, message="": done.append((ok, message)))
    qtbot.waitUntil(lambda: bool(done), timeout=30000)
    wait_idle(qtbot, lab_page)
    assert done == [(True, "")]
    assert is_synthetic(lab_page.measurements_path())
    assert lab_page.state.project.path("calibrated").is_file() and lab_page.is_complete()


# -- options, Cancel, bad input (hardware-mode projects: no lab to build) --------------------
def test_options_reach_the_identification(hw_page, qtbot):
    page = hw_page
    write_synthetic(page)
    page.on_enter()
    page.options.validation_combo.setCurrentIndex(2)
    page.options.kfold_spin.setValue(3)
    page.options.huber_check.setChecked(True)
    page.options.huber_spin.setValue(2.5)
    page.options.fix_edit.setText("j5.d, marker.z")           # case-insensitive, canonical names come back
    assert page.fixed_names() == ["J5.d", "marker.z"]
    identify(qtbot, page)
    result = page.result
    assert result.validation.method == "kfold" and result.validation.folds == 3
    assert result.huber == 2.5
    for name in ("J5.d", "marker.z"):
        r = [row.name for row in result.parameters].index(name)
        assert result.parameters[r].status == FIXED_BY_USER and page.results.table.is_greyed(r)
    assert page.state.accuracy is None      # no true robot in hardware mode
    assert "3-fold cross validation" in page.results.validation_view.toPlainText()


def test_deflection_choice_payload_and_verdict_on_the_page(hw_page, qtbot):
    page = hw_page
    true = deflecting_robot(perturbed_model(page.state.robot, 2), 2, range_deg=(0.05, 0.08))
    write_measurements(simulate_measurements(true, 40, sigma_mm=0.03, rng=3), page.measurements_path())
    page.on_enter()
    page.options.deflection_combo.setCurrentIndex(1)           # "Deflection if it helps"
    assert page.options.compliance() == "auto" and "J2.cos_q2" in page.options.fix_actions
    page.options.payload_check.setChecked(True)
    page.options.payload_spin.setValue(1.5)
    identify(qtbot, page)
    result = page.result
    assert result.compliance.mode == "auto" and result.compliance.kept and result.payload_kg == 1.5
    text = page.results.validation_view.toPlainText()
    assert "Deflection under the arm's weight" in text and "The arm bends under its weight" in text
    assert "Payload during the measurements: 1.5 kg" in text
    assert any(row.name == "J3.sin_q23" and row.identifiable for row in result.parameters)
    page.options.deflection_combo.setCurrentIndex(0)
    assert "J2.cos_q2" not in page.options.fix_actions and page.options.options().compliance == "off"


def test_fix_menu_and_text_agree(hw_page):
    page = hw_page
    page.options.fix_edit.setText("J2.a")
    page.options.fix_edit.textEdited.emit("J2.a")
    assert page.options.fix_actions["J2.a"].isChecked()
    page.options.fix_actions["base.rz"].setChecked(True)
    assert page.options.fix_edit.text() == "J2.a, base.rz"


def test_unknown_parameter_to_fix_is_refused_on_the_page(hw_page):
    write_synthetic(hw_page)
    hw_page.on_enter()
    hw_page.options.fix_edit.setText("J9.a")
    assert not hw_page.start_identification()
    assert "unknown parameter 'J9.a'" in hw_page.status.text() and not hw_page.task.busy


def test_cancel_keeps_the_page_usable(hw_page, qtbot):
    page = hw_page
    write_synthetic(page)
    page.on_enter()
    assert page.start_identification()
    assert page.task.progress_row().cancel_button.isEnabled() and not page.options.run_button.isEnabled()
    qtbot.mouseClick(page.task.progress_row().cancel_button, Qt.MouseButton.LeftButton)
    wait_idle(qtbot, page)
    assert page.status.text().startswith("Cancelled") and page.result is None
    assert not page.is_complete() and page.state.identification is None
    assert page.options.run_button.isEnabled() and not page.task.progress_row().cancel_button.isEnabled()
    identify(qtbot, page)                                  # and it still works afterwards
    assert page.is_complete()


@pytest.mark.parametrize("content, expected", [
    ("# robocal.measurements/1\npose,target,q1,q2,q3,q4,q5,q6,x,y,z\n0,marker,1,2,3,4,5,six,1,2,3\n",
     "line 3"),
    ("# robocal.measurements/1\npose,target,q1,q2,q3,x,y,z\n0,marker,1,2,3,1,2,3\n", "joint"),
    ("not a measurements file at all\n", "measurements.csv"),
])
def test_a_bad_measurements_file_gives_a_clear_message(hw_page, qtbot, content, expected):
    page = hw_page
    page.measurements_path().write_text(content)
    page.on_enter()
    assert "cannot be used" in page.source.source_label.text() and expected in page.source.source_label.text()
    assert not page.options.run_button.isEnabled()
    assert page.start_identification()                    # the worker reads the file and reports
    wait_idle(qtbot, page)
    assert page.status.text().startswith("✗") and expected in page.status.text()
    assert "Traceback" not in page.status.text() and page.result is None and not page.is_complete()
    assert not page.state.project.path("calibrated").exists()


def test_too_few_poses_is_reported_not_crashed(hw_page, qtbot):
    write_synthetic(hw_page, n_poses=3)
    hw_page.on_enter()
    hw_page.options.validation_combo.setCurrentIndex(0)
    identify(qtbot, hw_page)
    assert hw_page.status.text().startswith("✗") and hw_page.result is None
    assert "pose" in hw_page.status.text()


def test_autopilot_without_measurements_in_hardware_mode_fails_clearly(hw_page):
    done = []
    hw_page.autopilot(lambda ok=True, message="": done.append((ok, message)))
    assert done and done[0][0] is False and "Measurement step" in done[0][1]


def test_a_new_project_clears_the_result(hw_page, qtbot, tmp_path):
    write_synthetic(hw_page)
    hw_page.on_enter()
    identify(qtbot, hw_page)
    assert hw_page.is_complete()
    hw_page.state.new_project(tmp_path / "other", mode=projects.HARDWARE)
    assert not hw_page.is_complete() and hw_page.results.table.rowCount() == 0
    assert "No measurements" in hw_page.source.source_label.text()


def test_prior_option_reaches_the_identification_and_is_reported(hw_page, qtbot):
    page = hw_page
    write_synthetic(page)
    page.on_enter()
    assert page.options.options().prior is None
    page.options.prior_check.setChecked(True)
    identify(qtbot, page)
    prior = page.result.prior
    assert prior is not None and prior.chosen_by == "empirical Bayes" and not prior.weights.plain
    text = page.results.validation_view.toPlainText()
    assert "Prior toward nominal" in text and f"Weight {prior.weight_text}" in text


def test_orientation_option_determines_the_last_joint_zero(hw_page, qtbot):
    page = hw_page
    robot = page.state.robot
    true = perturbed_model(robot, 3, target_mm=0.0)              # the marker on the last joint's axis
    meas = simulate_measurements(true, 30, sigma_mm=0.02, rng=4, with_sigma=True, orientation_sigma_deg=0.02)
    write_measurements(meas, page.measurements_path())
    page.on_enter()
    assert page.options.options().orientation is False and "marker.rz" not in page.options.fix_actions
    page.options.orientation_check.setChecked(True)
    assert "marker.rz" in page.options.fix_actions                # the Choose menu offers the marker's turn
    page.options.fix_actions["marker.rz"].setChecked(True)
    assert page.fixed_names() == ["marker.rz"]
    identify(qtbot, page)
    result = page.result
    assert result.orientation is not None and result.orientation.determined == ["J6.theta"]
    assert result.row("J6.theta").identifiable
    text = page.results.validation_view.toPlainText()
    assert "Marker orientation" in text and "Determined only thanks to the orientation: J6.theta" in text
