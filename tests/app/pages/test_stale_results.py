"""Words that follow the project: a result made from other inputs than the project now has is
called out of date (Identification, Marker) and its step is not done until run again; the Check
page sees a calibrated.json saved in the same session; the Marker page inside a project says what
to do; the Setup page reads the joints again after another step moved the robot; measurements taken
with another stereo calibration are out of date."""
from __future__ import annotations

import numpy as np
import pytest

from app.jobs.marker import save_trained, write_verification
from app.main_window import MainWindow
from app.pages.check.page import MISSING, CheckPage
from app.pages.identification.page import IdentificationPage
from app.pages.marker.page import MarkerPage
from app.pages.measurement.page import MeasurementPage
from app.pages.setup.page import SetupPage
from app.pages.steps import Step
from app.state import WizardState
from app.worker import TaskRunner
from core import project as projects
from core.measurement.file import write_measurements
from core.poses.file import write_poses
from core.provenance import inputs_file
from core.virtual_lab.synthetic import perturbed_model, simulate_measurements
from tests.app.virtual_inputs import lab_marker, lab_state, make_lab, true_stereo_yaml
from widgets.step_list import StepState

TIMEOUT = 120_000


@pytest.fixture(scope="module")
def lab():
    return make_lab()


@pytest.fixture
def made(qtbot):
    """Pages made by a test (shown offscreen), their tasks and states closed after it."""
    pages = []

    def make(cls, state, tasks):
        page = cls(state, tasks)
        qtbot.addWidget(page)
        page.resize(1100, 760)
        page.show()
        page.on_enter()
        pages.append(page)
        return page

    yield make
    for page in pages:
        page.task.runner.shutdown()
    for state in {id(p.state): p.state for p in pages}.values():
        state.close()


def idle(qtbot, page):
    qtbot.waitUntil(lambda: not page.task.busy, timeout=TIMEOUT)


def measure(page, seed):
    """Synthetic measurements of a perturbed arm written as the project's measurements.csv."""
    true = perturbed_model(page.state.robot, seed)
    path = write_measurements(simulate_measurements(true, 30, sigma_mm=0.05, rng=seed + 1), page.measurements_path())
    page.state.set_measurements(path)               # what the Measurement page does after a run
    return path


def test_identification_is_out_of_date_after_new_measurements(qtbot, tmp_path, made):
    state = WizardState()
    state.new_project(tmp_path / "cell", mode=projects.HARDWARE)
    state.choose_preset("educational_6r")
    page = made(IdentificationPage, state, TaskRunner())
    measure(page, 1)
    assert page.start_identification(), page.status.text()
    idle(qtbot, page)
    assert page.is_complete() and page.save_calibrated()
    assert inputs_file(page.state.project.path("calibrated")).is_file()
    measure(page, 5)                                  # another run of the Measurement step
    assert not page.is_complete() and page.changed_inputs() == ["measurements.csv"]
    assert page.status.text().startswith("Out of date: the identification was made from other inputs (")
    assert "Identify again" in page.status.text()
    page.grab().save(str(tmp_path / "identification-out-of-date.png"))
    # the next session knows it from calibrated.json's side file
    later = made(IdentificationPage, state, TaskRunner())
    assert later.run_result is None and later.changed_inputs() == ["measurements.csv"]
    assert "Out of date" in later.status.text()
    assert page.start_identification()
    idle(qtbot, page)
    assert page.is_complete() and page.changed_inputs() == [] and page.status.text().startswith("✓ Identified")


def test_check_sees_the_calibration_saved_in_this_session(qtbot, lab, tmp_path, made):
    state = lab_state(lab, stereo=False)
    tasks = TaskRunner()
    check = made(CheckPage, state, tasks)
    assert check.status.text() == MISSING and not check.controls.run_button.isEnabled()
    ident = made(IdentificationPage, state, tasks)
    assert ident.use_ideal_measurements(then_identify=True)
    qtbot.waitUntil(lambda: ident.run_result is not None and not ident.task.busy, timeout=TIMEOUT)
    assert ident.save_calibrated()
    # the Check page was not entered again: the saved file alone changes its words
    assert check.status.text() != MISSING and "Ready to check" in check.status.text(), check.status.text()
    assert check.controls.run_button.isEnabled()
    check.grab().save(str(tmp_path / "check-ready.png"))


def test_marker_inside_a_project_and_out_of_date_after_a_new_stereo_calibration(qtbot, lab, tmp_path, made):
    state = lab_state(lab)
    page = made(MarkerPage, state, TaskRunner())
    assert "No project" not in page.status.text()
    assert page.status.text().startswith("No trained marker in this project yet")
    page.task.runner.shutdown()
    # a trained and verified marker, then the Stereo step saves another stereo.yaml
    project = state.project
    save_trained(project, lab_marker(lab))
    write_verification(project, "marker.npz", {"kind": "live pair", "poses": 1, "located": 1})
    page = made(MarkerPage, state, TaskRunner())
    assert page.is_complete() and "already has a trained marker" in page.status.text()
    text = project.path("stereo").read_text().replace("0.02", "0.05")      # its reprojection errors
    project.path("stereo").write_text(text)
    page.on_enter()
    assert not page.is_complete()
    assert page.status.text().startswith("Out of date: the marker's verification was made from other inputs (")
    assert "stereo.yaml changed" in page.status.text()
    page.grab().save(str(tmp_path / "marker-out-of-date.png"))
    assert page.next_pose()                           # locate again with the new calibration
    idle(qtbot, page)
    assert page.is_complete() and page.changed_inputs() == [], page.status.text()
    true_stereo_yaml(lab, project.path("stereo"))     # and back: out of date again
    page.on_enter()
    assert not page.is_complete()


def test_setup_reads_the_joints_again_after_another_step_moved_the_robot(qtbot, lab, made):
    state = lab_state(lab, stereo=False)
    page = made(SetupPage, state, TaskRunner())
    panel = page.robot_panel
    assert panel.read_joints()
    idle(qtbot, page)
    before = state.robot.q_to_file(panel.joints)
    assert panel.joints_label.text() == "Joints: " + "  ".join(f"{v:.2f}" for v in before)
    lo, hi = state.robot.limits()
    q = np.clip(panel.joints + 0.3, lo, hi)          # a measurement run left the robot elsewhere
    state.hardware.robot_connection.move_to(q)
    page.on_leave()
    page.on_enter()
    assert not panel.jog_plus.isEnabled()             # no jog from the old reading meanwhile
    idle(qtbot, page)
    after = state.robot.q_to_file(panel.joints)
    assert np.allclose(panel.joints, q, atol=1e-6)
    assert panel.joints_label.text() == "Joints: " + "  ".join(f"{v:.2f}" for v in after)
    assert panel.joints_label.text() != "Joints: " + "  ".join(f"{v:.2f}" for v in before)


def test_the_step_list_marks_an_out_of_date_step(qtbot, tmp_path):
    state = WizardState()
    state.new_project(tmp_path / "cell", mode=projects.HARDWARE)
    state.choose_preset("educational_6r")
    window = MainWindow(state)
    qtbot.addWidget(window)
    window.resize(1280, 720)
    window.show()
    try:
        page = window.go_to(Step.IDENTIFICATION)
        row = int(Step.IDENTIFICATION)
        assert window.step_list.state(row) is StepState.TODO
        measure(page, 1)
        assert page.start_identification()
        idle(qtbot, page)
        assert window.step_list.state(row) is StepState.DONE and window.next_button.isEnabled()
        measure(page, 5)
        assert window.step_list.state(row) is StepState.STALE and not window.next_button.isEnabled()
        assert "out of date: run again" in window.step_list.item(row).text()
        window.grab().save(str(tmp_path / "window-identification-out-of-date.png"))
        assert page.start_identification()
        idle(qtbot, page)
        assert window.step_list.state(row) is StepState.DONE
    finally:
        window.close()


@pytest.mark.slow
def test_measurements_are_out_of_date_after_a_new_stereo_calibration(qtbot, lab, tmp_path, made):
    state = lab_state(lab)
    lab_marker(lab).save(state.project.folder / "marker.npz")
    write_poses(state.project.path("poses"), lab.nominal_robot.q_to_file(
        lab.random_visible_poses(10, np.random.default_rng(5))))
    page = made(MeasurementPage, state, TaskRunner())
    assert page.start_run()
    idle(qtbot, page)
    assert page.is_complete() and page.changed_inputs() == [], page.status.text()
    assert inputs_file(page.measurements_path()).is_file()
    path = state.project.path("stereo")
    path.write_text(path.read_text().replace("0.02", "0.05"))
    page.on_enter()
    assert not page.is_complete() and page.changed_inputs() == ["stereo.yaml"]
    assert page.status.text().startswith("Out of date: measurements.csv was made from other inputs (stereo.yaml")
    assert "Start over" in page.status.text()
    page.grab().save(str(tmp_path / "measurement-out-of-date.png"))
    assert page.start_over(confirm=False) and page.start_run()
    idle(qtbot, page)
    assert page.is_complete() and page.changed_inputs() == [], page.status.text()
