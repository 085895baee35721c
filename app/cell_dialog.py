"""Which cell a project measures on, asked when a project is made and from the Setup page:
the virtual lab (the demo, teaching), or a real cell: its robot connection (a serial port and the
controller's protocol profile, or none: teach mode, the robot brought to each pose by hand) and
its two cameras (each a device index, a device path, a video file or an image folder).

`CellDialog.cell()` gives (mode, robot_connection, cameras) as core.project stores them;
`change_cell` asks and makes it the project's cell (the Setup page's Change cell…)."""
from __future__ import annotations

from PySide6.QtWidgets import (QButtonGroup, QComboBox, QDialog, QDialogButtonBox, QGridLayout, QGroupBox, QLabel,
                               QLineEdit, QRadioButton, QVBoxLayout, QWidget)

from app.messages import show_error
from core import project as projects
from core.errors import RoboCalError
from core.robot.profile import builtin_names


class CellDialog(QDialog):
    """Virtual lab or real cell; for a real cell its robot connection and cameras. `project`:
    the values shown first (its current cell), None for a new project."""

    def __init__(self, parent: QWidget | None = None, project: projects.Project | None = None):
        super().__init__(parent)
        self.setWindowTitle("RoboCal: the project's cell")
        self.virtual_radio = QRadioButton("Virtual lab: a simulated robot and cameras (demo, teaching)")
        self.virtual_radio.setObjectName("cellVirtualRadio")
        self.real_radio = QRadioButton("A real cell: a robot and two cameras (or recordings of them)")
        self.real_radio.setObjectName("cellRealRadio")
        kinds = QButtonGroup(self)
        kinds.addButton(self.virtual_radio)
        kinds.addButton(self.real_radio)

        self.serial_radio = QRadioButton("Serial robot")
        self.serial_radio.setObjectName("cellSerialRadio")
        self.teach_radio = QRadioButton("No connection: teach mode (you bring the robot to each pose and type "
                                        "or read its joints)")
        self.teach_radio.setObjectName("cellTeachRadio")
        robots = QButtonGroup(self)
        robots.addButton(self.serial_radio)
        robots.addButton(self.teach_radio)
        self.port_edit = QLineEdit()
        self.port_edit.setObjectName("cellPortEdit")
        self.port_edit.setPlaceholderText("/dev/ttyUSB0, /dev/ttyACM0, COM3 …")
        self.profile_combo = QComboBox()
        self.profile_combo.setObjectName("cellProfileCombo")
        self.profile_combo.setEditable(True)
        self.profile_combo.addItems(builtin_names())
        self.profile_combo.setCurrentText("robocal_v1")
        robot_box = QGroupBox("Robot connection")
        rl = QGridLayout(robot_box)
        rl.addWidget(self.serial_radio, 0, 0, 1, 4)
        rl.addWidget(QLabel("Port:"), 1, 1)
        rl.addWidget(self.port_edit, 1, 2)
        rl.addWidget(QLabel("Protocol:"), 2, 1)
        rl.addWidget(self.profile_combo, 2, 2)
        rl.addWidget(self.teach_radio, 3, 0, 1, 4)

        self.left_edit = QLineEdit()
        self.left_edit.setObjectName("cellLeftEdit")
        self.right_edit = QLineEdit()
        self.right_edit.setObjectName("cellRightEdit")
        for edit in (self.left_edit, self.right_edit):
            edit.setPlaceholderText("0, /dev/video2, a video file or an image folder")
        self.cameras_box = QGroupBox("Cameras")
        cl = QGridLayout(self.cameras_box)
        cl.addWidget(QLabel("Left:"), 0, 0)
        cl.addWidget(self.left_edit, 0, 1)
        cl.addWidget(QLabel("Right:"), 1, 0)
        cl.addWidget(self.right_edit, 1, 1)
        self.robot_box = robot_box

        buttons = QDialogButtonBox(QDialogButtonBox.StandardButton.Ok | QDialogButtonBox.StandardButton.Cancel)
        buttons.accepted.connect(self.accept)
        buttons.rejected.connect(self.reject)
        note = QLabel("A real cell is never simulated: every step measures with its robot and cameras. "
                      "You can change this later on the Setup page.")
        note.setWordWrap(True)
        layout = QVBoxLayout(self)
        layout.addWidget(self.virtual_radio)
        layout.addWidget(self.real_radio)
        layout.addWidget(self.robot_box)
        layout.addWidget(self.cameras_box)
        layout.addWidget(note)
        layout.addWidget(buttons)

        for radio in (self.real_radio, self.serial_radio):
            radio.toggled.connect(lambda *_: self._refresh())
        self.show_cell(project)

    def show_cell(self, project: projects.Project | None) -> None:
        robot = (project.robot_connection if project is not None else None) or projects.RobotConnection("")
        cams = (project.cameras if project is not None else None) or projects.CameraSources("")
        (self.real_radio if project is not None and project.real_cell else self.virtual_radio).setChecked(True)
        (self.teach_radio if robot.kind == projects.TEACH else self.serial_radio).setChecked(True)
        self.port_edit.setText(robot.port or "")
        self.profile_combo.setCurrentText(robot.profile or "robocal_v1")
        self.left_edit.setText(cams.left or "")
        self.right_edit.setText(cams.right or "")
        self._refresh()

    def _refresh(self) -> None:
        real = self.real_radio.isChecked()
        self.robot_box.setEnabled(real)
        self.cameras_box.setEnabled(real)
        self.port_edit.setEnabled(self.serial_radio.isChecked())
        self.profile_combo.setEnabled(self.serial_radio.isChecked())

    def cell(self) -> tuple[str, projects.RobotConnection | None, projects.CameraSources | None]:
        """(mode, robot_connection, cameras) for core.project; the last two None for the lab."""
        if not self.real_radio.isChecked():
            return projects.VIRTUAL_LAB, None, None
        if self.serial_radio.isChecked():
            robot = projects.RobotConnection(projects.SERIAL, port=self.port_edit.text().strip(),
                                             profile=self.profile_combo.currentText().strip() or "robocal_v1")
        else:
            robot = projects.RobotConnection(projects.TEACH)
        cameras = projects.CameraSources(projects.SOURCES, left=self.left_edit.text().strip(),
                                         right=self.right_edit.text().strip())
        return projects.HARDWARE, robot, cameras


def ask_cell(parent: QWidget | None, project: projects.Project | None = None):
    """(mode, robot_connection, cameras) chosen in the dialog, or None when cancelled."""
    dialog = CellDialog(parent, project)
    try:
        return dialog.cell() if dialog.exec() == QDialog.DialogCode.Accepted else None
    finally:
        dialog.deleteLater()


def change_cell(parent: QWidget | None, state, cell: tuple[str, dict | None, dict | None] | None = None) -> bool:
    """Make `cell` (asked in the dialog when not given) the cell of `state`'s project
    (WizardState.set_cell); a RoboCalError is shown as one message box line."""
    if state.project is None:
        show_error(parent, "No project: create or open one first.", "RoboCal: cell")
        return False
    if cell is None:
        cell = ask_cell(parent, state.project)
        if cell is None:
            return False
    mode, robot_connection, cameras = cell
    try:
        state.set_cell(mode, robot_connection=robot_connection, cameras=cameras)
    except RoboCalError as exc:
        show_error(parent, exc.message, "RoboCal: cell")
        return False
    return True
