"""A new user on a 1280×720 screen, start to finish without leaving the wizard: New project in a
folder typed by name (a real cell, teach mode), Load URDF… with the UR5's tip chosen, one mixed
folder of real leftNN/rightNN pairs, the swapped cameras fixed on the spot, and a calibrated
stereo rig saved. The window keeps the screen's size, no control is cut and none overlaps another at
every stage; a
screenshot of each stage is saved (besides pytest's folder, in $ROBOCAL_SMALL_SCREEN_SHOTS)."""
from __future__ import annotations

import os
import shutil
from pathlib import Path

import pytest
from PySide6.QtCore import Qt, QTimer
from PySide6.QtWidgets import QApplication, QDialogButtonBox, QLineEdit

from app import project_actions
from app.cell_dialog import CellDialog
from app.new_folder_dialog import NewFolderDialog, ask_new_folder
from app.pages.setup.urdf_dialog import UrdfDialog
from app.pages.steps import Step
from core.stereo.file import read_stereo_yaml
from tests.app.test_small_screens import SHOTS_ENV, cut_controls, overlapping, settle
from tests.core.stereo_synth import REAL_DATA

UR5 = Path(__file__).resolve().parents[1] / "data" / "real" / "ur5_robot.urdf"
WAIT_MS = 240_000


def when_modal(kind, act) -> None:
    """Once a modal dialog of type `kind` is open: `act(dialog)`."""
    def poll():
        dialog = QApplication.activeModalWidget()
        if not isinstance(dialog, kind):
            QTimer.singleShot(50, poll)
            return
        act(dialog)
    QTimer.singleShot(0, poll)


@pytest.fixture
def window(qtbot):
    from app import messages
    from app.main_window import MainWindow
    from app.state import WizardState

    state = WizardState()
    win = MainWindow(state)
    qtbot.addWidget(win)
    win.resize(1280, 720)
    win.show()
    yield win
    messages.set_non_interactive(True)
    try:
        win.close()
    finally:
        messages.set_non_interactive(False)
    state.close()


@pytest.mark.skipif(not REAL_DATA.is_dir(), reason=f"real checkerboard pairs not found at {REAL_DATA}")
def test_a_new_user_reaches_a_calibrated_stereo_rig_on_a_small_screen(window, qtbot, tmp_path, monkeypatch):
    win = window
    shots = [tmp_path / "shots"] + ([Path(os.environ[SHOTS_ENV])] if os.environ.get(SHOTS_ENV) else [])

    def stage(name: str) -> None:
        """The window still the screen's size, nothing cut on the page, and its picture."""
        settle(win, 1280, 720)             # the layouts settle (a wrapped row's new height travels up)
        assert (win.width(), win.height()) == (1280, 720), name
        assert cut_controls(win) == [], name
        assert overlapping(win.current_page()) == [], name
        image = win.grab()
        for folder in shots:
            folder.mkdir(parents=True, exist_ok=True)
            assert image.save(str(folder / f"walk-{name}.png"))

    # 1. New project: a folder typed by name, a real cell whose robot is brought by hand
    monkeypatch.setattr(project_actions, "ask_new_folder",
                        lambda parent, title: ask_new_folder(parent, title, tmp_path))

    def name_folder(dialog):
        edit = dialog.findChild(QLineEdit, "fileNameEdit")
        edit.clear()
        qtbot.keyClicks(edit, "Cell 7 calibration")
        qtbot.mouseClick(dialog.accept_button(), Qt.MouseButton.LeftButton)
        when_modal(CellDialog, choose_cell)

    def choose_cell(dialog):
        dialog.real_radio.setChecked(True)
        dialog.teach_radio.setChecked(True)
        dialog.left_edit.setText("0")
        dialog.right_edit.setText("1")
        qtbot.mouseClick(dialog.findChild(QDialogButtonBox).button(QDialogButtonBox.StandardButton.Ok),
                         Qt.MouseButton.LeftButton)

    when_modal(NewFolderDialog, name_folder)
    win.action_new.trigger()
    project = win.state.project
    assert project is not None and project.folder == tmp_path / "Cell 7 calibration"
    assert project.real_cell and project.teach_mode
    stage("1-new-project")

    # 2. Load URDF…: the UR5, its tip link chosen in the dialog
    setup = win.page(Step.SETUP)
    monkeypatch.setattr("app.pages.setup.page.QFileDialog.getOpenFileName", lambda *a, **kw: (str(UR5), ""))

    def choose_tip(dialog):
        dialog.tip_combo.setCurrentIndex(dialog.tip_combo.findData("tool0"))
        qtbot.mouseClick(dialog.buttons.button(QDialogButtonBox.StandardButton.Ok), Qt.MouseButton.LeftButton)

    when_modal(UrdfDialog, choose_tip)
    qtbot.mouseClick(setup.urdf_button, Qt.MouseButton.LeftButton)
    assert win.state.robot is not None and win.state.robot.dof == 6
    assert (project.folder / "robot.json").is_file()
    assert setup.dh_table.cell_text(0, 0) == "shoulder_pan_joint"
    stage("2-ur5-urdf")
    assert win.can_go_next()
    qtbot.mouseClick(win.next_button, Qt.MouseButton.LeftButton)
    assert win.current_step is Step.STEREO

    # 3. one mixed folder of real leftNN/rightNN pairs (9 × 6 inner corners, 24 mm squares)
    stereo = win.page(Step.STEREO)
    mixed = tmp_path / "our pairs"
    shutil.copytree(REAL_DATA, mixed, ignore=shutil.ignore_patterns("*.md"))
    stereo.pairs.cols_spin.setValue(9)
    stereo.pairs.rows_spin.setValue(6)
    stereo.pairs.square_spin.setValue(24.0)
    stereo.apply_board()
    answers = [str(mixed)]
    monkeypatch.setattr("app.pages.stereo.pairs_panel.QFileDialog.getExistingDirectory",
                        lambda *a, **kw: answers.pop(0))          # one folder: a second question would fail
    qtbot.mouseClick(stereo.pairs.folders_button, Qt.MouseButton.LeftButton)
    qtbot.waitUntil(lambda: not stereo.task.busy, timeout=WAIT_MS)
    assert len(stereo.items) == 25 and len(stereo.usable_pairs()) == 25
    qtbot.mouseClick(stereo.options_panel.calibrate_button, Qt.MouseButton.LeftButton)
    qtbot.waitUntil(lambda: stereo.result is not None and not stereo.task.busy, timeout=WAIT_MS)
    assert stereo.result.cameras_look_swapped and stereo.swap_button.isVisible()
    assert "Swap left and right" in stereo.status.text()
    stage("3-swapped-cameras")

    # 4. fixed on the spot: swapped and calibrated again, then saved
    qtbot.mouseClick(stereo.swap_button, Qt.MouseButton.LeftButton)
    qtbot.waitUntil(lambda: stereo.result is not None and not stereo.task.busy
                    and not stereo.result.cameras_look_swapped, timeout=WAIT_MS)
    result = stereo.result
    assert result.pairs_used == 25 and result.file.rms_stereo < 0.5
    assert -result.file.T[0] > 0.9 * result.baseline_mm           # the right camera on the right
    qtbot.mouseClick(stereo.save_button, Qt.MouseButton.LeftButton)
    assert stereo.is_complete() and win.can_go_next()
    saved = read_stereo_yaml(project.path("stereo"))
    assert saved.rms_stereo == pytest.approx(result.file.rms_stereo)
    assert 85.0 < result.baseline_mm < 100.0          # the author's own run: |T| ≈ 92.0 mm
    stage("4-calibrated-rig")
