"""The cell dialog: the virtual lab by default, a real cell with a serial robot (port and protocol
profile) and two cameras, or teach mode (no robot connection to type)."""
from __future__ import annotations

from app.cell_dialog import CellDialog
from core import project as projects


def test_the_dialog_gives_a_real_cell_with_a_serial_robot_or_teach_mode(qtbot):
    dialog = CellDialog()
    qtbot.addWidget(dialog)
    assert dialog.cell() == (projects.VIRTUAL_LAB, None, None)
    assert not dialog.robot_box.isEnabled()
    dialog.real_radio.setChecked(True)
    dialog.port_edit.setText(" /dev/ttyACM0 ")
    dialog.profile_combo.setCurrentText("grbl_joint_arm")
    dialog.left_edit.setText("0")
    dialog.right_edit.setText("/data/right")
    assert dialog.cell() == (projects.HARDWARE,
                             projects.RobotConnection("serial", port="/dev/ttyACM0", profile="grbl_joint_arm"),
                             projects.CameraSources("sources", left="0", right="/data/right"))
    dialog.teach_radio.setChecked(True)
    assert not dialog.port_edit.isEnabled()
    assert dialog.cell()[1] == projects.RobotConnection("teach")
