"""A URDF loaded on the Setup page (Load URDF…, or a .urdf given to Load robot.json…): the dialog
lists the URDF's links with the base and tip `robocal robot-import` takes by default, shows
the chain's joints or why it cannot be imported, and the chosen chain becomes the robot and the
project's robot.json. Real URDFs of tests/data/real/ (its README names their sources)."""
from __future__ import annotations

from html import unescape
from pathlib import Path

import numpy as np
import pytest
from PySide6.QtCore import QTimer
from PySide6.QtWidgets import QApplication, QDialogButtonBox, QMessageBox

from app.pages.setup.page import SetupPage
from app.pages.setup.urdf_dialog import UrdfDialog
from app.state import WizardState
from app.worker import TaskRunner
from core.robot.file import read_robot
from core.robot.urdf_import import urdf_forward_kinematics

REAL = Path(__file__).resolve().parents[2] / "data" / "real"
UR5 = REAL / "ur5_robot.urdf"
PANDA_HAND = REAL / "franka_panda_hand.urdf"
PANDA = REAL / "franka_panda.urdf"


@pytest.fixture
def page(qtbot, tmp_path):
    state, tasks = WizardState(), TaskRunner()
    state.new_project(tmp_path / "project")
    p = SetupPage(state, tasks)
    qtbot.addWidget(p)
    p.resize(1200, 900)
    p.show()
    yield p
    p.on_leave()
    tasks.shutdown()
    state.close()


def _answer(qtbot, act, seen: dict) -> None:
    """Once the URDF dialog is open: `act(dialog)` (it records what it sees in `seen`), then OK
    if it is enabled, else Cancel."""
    def answer():
        dialog = QApplication.activeModalWidget()
        if not isinstance(dialog, UrdfDialog):
            QTimer.singleShot(50, answer)
            return
        act(dialog)
        ok = dialog.buttons.button(QDialogButtonBox.StandardButton.Ok)
        seen["ok_enabled"] = ok.isEnabled()
        (ok if ok.isEnabled() else dialog.buttons.button(QDialogButtonBox.StandardButton.Cancel)).click()
    QTimer.singleShot(0, answer)


def _choose(combo, link: str) -> None:
    combo.setCurrentIndex(combo.findData(link))


def _same_fk(model, path, tip, seed=3):
    rng = np.random.default_rng(seed)
    lo, hi = model.limits()
    for q in rng.uniform(lo, hi, size=(5, model.dof)):
        np.testing.assert_allclose(model.fk(q), urdf_forward_kinematics(path, q, tip=tip), atol=1e-6)


def test_the_ur5_with_its_tip_chosen_becomes_the_projects_robot(page, qtbot):
    seen: dict = {}

    def act(dialog):
        seen["base"] = dialog.base_combo.currentData()
        seen["tip"] = dialog.tip_combo.currentData()
        seen["links"] = [dialog.tip_combo.itemData(i) for i in range(1, dialog.tip_combo.count())]
        seen["note"] = unescape(dialog.default_note.text())
        seen["ok_before"] = dialog.buttons.button(QDialogButtonBox.StandardButton.Ok).isEnabled()
        _choose(dialog.tip_combo, "tool0")
        seen["preview"] = unescape(dialog.preview.text())

    _answer(qtbot, act, seen)
    model = page.load_urdf(UR5)
    # the command's defaults: the root link as base; two end links, so the tip is asked for
    assert seen["base"] == "world" and seen["tip"] is None and not seen["ok_before"]
    assert "Choose the tip link: the URDF has 2 end links (ee_link, tool0)" in seen["note"]
    assert {"base_link", "shoulder_link", "wrist_3_link", "ee_link", "tool0"} <= set(seen["links"])
    names = ["shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint", "wrist_1_joint", "wrist_2_joint",
             "wrist_3_joint"]
    assert "6 joints" in seen["preview"] and ", ".join(names) in seen["preview"]
    assert seen["ok_enabled"] and model is not None and [j.name for j in model.joints] == names
    saved = read_robot(page.state.project.path("robot"))
    assert [j.name for j in saved.joints] == names
    _same_fk(saved, UR5, "tool0")
    assert page.state.robot is model and page.state.project.robot_source == str(UR5)
    assert page.dh_table.rowCount() == 6 and page.dh_table.cell_text(0, 0) == "shoulder_pan_joint"
    assert page.preset_combo.currentText() == "From file: ur5_robot.urdf"
    assert "6 joints from 'world' to 'tool0' of ur5_robot.urdf" in page.status.text()


def test_a_tip_after_the_pandas_mimic_finger_is_refused_in_the_dialog_and_the_hand_accepted(page, qtbot):
    seen: dict = {}

    def act(dialog):
        seen["base"] = dialog.base_combo.currentData()
        _choose(dialog.tip_combo, "panda_rightfinger")
        seen["finger"] = unescape(dialog.preview.text())
        seen["finger_ok"] = dialog.buttons.button(QDialogButtonBox.StandardButton.Ok).isEnabled()
        _choose(dialog.tip_combo, "panda_hand")
        seen["hand"] = unescape(dialog.preview.text())

    _answer(qtbot, act, seen)
    model = page.load_urdf(PANDA_HAND)
    assert seen["base"] == "panda_link0"
    assert "a mimic joint (coupled to another joint) cannot be part of a DH chain" in seen["finger"]
    assert "Choose a tip link before it (e.g. 'panda_hand')" in seen["finger"] and not seen["finger_ok"]
    assert "7 joints" in seen["hand"] and "the tip link 'panda_hand' is not the last DH frame" in seen["hand"]
    assert model.dof == 7
    _same_fk(read_robot(page.state.project.path("robot")), PANDA_HAND, "panda_hand")


def test_a_urdf_given_to_load_robot_json_goes_through_the_importer(page, qtbot):
    seen: dict = {}
    _answer(qtbot, lambda d: seen.update(base=d.base_combo.currentData(), tip=d.tip_combo.currentData()), seen)
    model = page.load_robot_file(PANDA)
    assert (seen["base"], seen["tip"]) == ("world", "panda_link8") and seen["ok_enabled"]   # the defaults
    assert model.dof == 7 and read_robot(page.state.project.path("robot")).dof == 7


def test_cancel_keeps_the_robot(page, qtbot):
    page.choose_preset("educational_6r")
    seen: dict = {}
    _answer(qtbot, lambda d: _choose(d.tip_combo, "panda_link0"), seen)      # the base link itself: refused
    assert page.load_urdf(PANDA_HAND) is None and not seen["ok_enabled"]
    assert page.state.robot_source == "preset:educational_6r"
    assert read_robot(page.state.project.path("robot")).name == page.state.robot.name


def test_an_unexpanded_xacro_says_to_run_xacro_first(page, tmp_path, monkeypatch):
    xacro = tmp_path / "arm.urdf.xacro"
    xacro.write_text('<robot xmlns:xacro="http://ros.org/wiki/xacro" name="arm">\n'
                     '  <xacro:property name="d1" value="0.089159"/>\n'
                     '  <link name="base"/><link name="l1"/>\n'
                     '  <joint name="j1" type="revolute"><parent link="base"/><child link="l1"/>\n'
                     '    <origin xyz="0 0 ${d1}"/><axis xyz="0 0 1"/></joint>\n</robot>\n')
    shown = []
    monkeypatch.setattr(QMessageBox, "critical", lambda parent, title, text: shown.append(text))
    assert page.load_robot_file(xacro) is None
    assert len(shown) == 1 and str(xacro) in shown[0] and "unexpanded xacro file" in shown[0]
    assert "Expand it first: xacro arm.urdf.xacro > robot.urdf" in shown[0]
    assert page.state.robot is None
