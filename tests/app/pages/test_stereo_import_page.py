"""The Stereo page's Import… button: another tool's calibration becomes the project's
stereo.yaml (statistics unknown), the step is done, and a bad file is one message."""
from __future__ import annotations

import numpy as np
import pytest
from PySide6.QtCore import Qt
from PySide6.QtWidgets import QFileDialog

from app.pages.measurement_inputs import stereo_source
from app.pages.stereo.page import StereoPage
from app.state import WizardState
from app.worker import TaskRunner
from core.project import HARDWARE
from core.report import calibration_report
from core.stereo.file import read_stereo_yaml
from tests.core.stereo import foreign_files as ff


@pytest.fixture
def page(qtbot, tmp_path):
    state, tasks = WizardState(), TaskRunner()
    state.new_project(tmp_path / "project", mode=HARDWARE)
    p = StereoPage(state, tasks)
    qtbot.addWidget(p)
    yield p
    p.task.runner.shutdown()
    p.state.close()


@pytest.fixture(scope="module")
def rig():
    from core.virtual_lab.rig import default_rig
    return default_rig(0)


def test_import_button_makes_a_ros_pair_the_projects_calibration(page, qtbot, tmp_path, rig, monkeypatch):
    left, right = ff.ros_pair(rig, tmp_path)
    assert not page.is_complete() and page.import_button.isEnabled()
    # the dialog returns the names sorted (right.yaml after left.yaml either way); the page puts left first
    monkeypatch.setattr(QFileDialog, "getOpenFileNames", lambda *a, **k: ([str(right), str(left)], ""))
    with qtbot.waitSignal(page.state.stereoChanged, timeout=2000):
        qtbot.mouseClick(page.import_button, Qt.MouseButton.LeftButton)
    assert page.is_complete()
    text = page.status.text()
    assert "Imported ROS camera_info pair" in text and "reprojection errors unknown" in text, text
    sf = read_stereo_yaml(page.state.project.path("stereo"))
    assert sf.rms_stereo is None and sf.board is None
    np.testing.assert_allclose(sf.T, rig.T, atol=1e-9)
    # the other steps read it, showing the unknown statistics as such
    source = stereo_source(page.state)
    assert source.kind == "file" and "stereo RMS —" in source.label
    assert "unknown (not in the imported calibration)" in calibration_report(page.state.project)
    # the page, opened again on the project, finds the step done
    again = StereoPage(page.state, page.task.runner)
    qtbot.addWidget(again)
    assert again.is_complete() and "stereo RMS —" in again.status.text()


def test_import_refusal_is_one_message_and_keeps_the_previous_file(page, tmp_path, rig):
    assert page.files.import_stereo([str(ff.opencv_file(rig, tmp_path / "good.yml"))]) is not None
    before = page.state.project.path("stereo").read_bytes()
    bad = ff.kalibr_camchain(rig, tmp_path / "camchain.yaml", model="equidistant")
    assert page.files.import_stereo([str(bad)]) is None
    text = page.status.text()
    assert text.startswith("Not imported: ") and "cam0.distortion_model" in text and "\n" not in text
    assert page.state.project.path("stereo").read_bytes() == before


def test_import_button_takes_a_matlab_mat_file(page, qtbot, tmp_path, rig, monkeypatch):
    """The dialog offers *.mat among the stereo calibrations; MATLAB's MAT-file is imported."""
    mat = ff.matlab_mat(rig, tmp_path / "stereoParams.mat")
    offered = []

    def dialog(parent, caption, folder, filters):
        offered.append(filters)
        return [str(mat)], ""
    monkeypatch.setattr(QFileDialog, "getOpenFileNames", dialog)
    with qtbot.waitSignal(page.state.stereoChanged, timeout=2000):
        qtbot.mouseClick(page.import_button, Qt.MouseButton.LeftButton)
    assert "*.mat" in offered[0].split(";;")[0]
    assert page.is_complete() and "Imported MATLAB stereoParameters (MAT)" in page.status.text()
    sf = read_stereo_yaml(page.state.project.path("stereo"))
    np.testing.assert_allclose(sf.K2, rig.right.K, rtol=1e-15)
