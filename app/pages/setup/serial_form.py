"""The serial robot's settings on the Setup page: port, protocol profile, baud rate, joint map
file and speed, with Connect and Disconnect (their clicks are the robot panel's to connect)."""
from __future__ import annotations

from PySide6.QtWidgets import QComboBox, QFileDialog, QGridLayout, QLabel, QLineEdit, QWidget

from app.hardware import SERIAL, RobotChoice
from app.pages import forms
from core.project import RobotConnection
from core.robot.profile import builtin_names
from core.robot.serial_robot import DEFAULT_SPEED

BAUD_RATES = ("9600", "57600", "115200", "230400", "250000", "1000000")


class SerialForm(QWidget):
    """`options()`: the serial robot chosen (app.hardware.RobotChoice; the speed apart, `speed()`,
    percent); `show_options(choice)` fills the fields with a recorded one."""

    def __init__(self, parent: QWidget | None = None):
        super().__init__(parent)
        self.port_edit = QLineEdit()
        self.port_edit.setObjectName("portEdit")
        self.port_edit.setPlaceholderText("/dev/ttyUSB0, /dev/ttyACM0, COM3 …")
        self.port_edit.setMinimumWidth(120)
        self.profile_combo = QComboBox()
        self.profile_combo.setObjectName("profileCombo")
        self.profile_combo.setEditable(True)
        self.profile_combo.addItems(builtin_names())
        self.profile_combo.setCurrentText("robocal_v1")
        self.profile_combo.setToolTip("The controller's protocol: a built-in profile, or the path of a profile file")
        self.joint_map_edit = QLineEdit()
        self.joint_map_edit.setObjectName("jointMapEdit")
        self.joint_map_edit.setPlaceholderText("optional: joint map file (units, sign, offset)")
        self.joint_map_button = forms.button("…", on_click=self._browse_joint_map,
                                             tooltip="Choose a joint map file (JSON)")
        self.baud_combo = QComboBox()
        self.baud_combo.setObjectName("baudCombo")
        self.baud_combo.setEditable(True)
        self.baud_combo.addItems(BAUD_RATES)
        self.baud_combo.setCurrentText("115200")
        self.speed_spin = forms.spin(int(DEFAULT_SPEED), 1, 100, name="speedSpin", suffix=" %",
                                     tooltip="Motion speed, percent of the robot's maximum (25 % for a first test)")
        self.connect_button = forms.button("Connect", "connectButton")
        self.disconnect_button = forms.button("Disconnect", "disconnectButton")
        form = QGridLayout(self)
        form.setContentsMargins(18, 0, 0, 0)
        form.addWidget(QLabel("Port:"), 0, 0)
        form.addWidget(self.port_edit, 0, 1, 1, 3)
        form.addWidget(QLabel("Protocol:"), 1, 0)
        form.addWidget(self.profile_combo, 1, 1)
        form.addWidget(QLabel("Baud:"), 1, 2)
        form.addWidget(self.baud_combo, 1, 3)
        form.addWidget(QLabel("Joint map:"), 2, 0)
        form.addLayout(forms.row(self.joint_map_edit, self.joint_map_button, stretch=False), 2, 1, 1, 3)
        form.addWidget(QLabel("Speed:"), 3, 0)
        form.addLayout(forms.row(self.speed_spin, self.connect_button, self.disconnect_button), 3, 1, 1, 3)

    def options(self) -> RobotChoice:
        baud = self.baud_combo.currentText().strip()
        return RobotChoice(SERIAL, self.port_edit.text().strip(), self.profile_combo.currentText().strip(),
                           self.joint_map_edit.text().strip(), int(baud) if baud.isdigit() else None)

    def speed(self) -> float:
        """Motion speed, percent of the robot's maximum."""
        return float(self.speed_spin.value())

    def show_options(self, saved: RobotConnection) -> None:
        """Show the serial robot a project recorded (core.project.RobotConnection, with its speed)."""
        self.port_edit.setText(saved.port or "")
        self.profile_combo.setCurrentText(saved.profile or "robocal_v1")
        self.joint_map_edit.setText(saved.joint_map or "")
        self.baud_combo.setCurrentText(str(saved.baud or "115200"))
        if saved.speed is not None:
            self.speed_spin.setValue(int(round(saved.speed)))

    def _browse_joint_map(self) -> None:
        path, _ = QFileDialog.getOpenFileName(self, "Joint map", "", "Joint map (*.json);;All files (*)")
        if path:
            self.joint_map_edit.setText(path)
