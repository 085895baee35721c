"""The Setup page's robot connection: the virtual lab's simulated robot or a controller on a
serial port (port, protocol profile, joint map file, baud rate, speed), and a test: connect
(the controller's answer to HELLO shown), read the joints, move one joint a small step inside
its limits (the first motion of a real robot is confirmed), Stop and Resume.

Everything that waits for the controller runs on the page's worker (page.task.start); Stop
calls the driver from the GUI thread at once, also during a move."""
from __future__ import annotations

import numpy as np
from PySide6.QtCore import Signal
from PySide6.QtWidgets import QButtonGroup, QComboBox, QGroupBox, QLabel, QRadioButton, QVBoxLayout, QWidget

from app.hardware import SERIAL, RobotChoice
from app.html import esc
from app.jobs.robot import Connected, connect_serial, move_and_read, read_joints
from app.pages import forms
from app.pages.setup.serial_form import SerialForm
from app.pages.setup.simulator_row import SimulatorRow
from app.safety import motion_refused
from core.errors import RoboCalError


class RobotPanel(QGroupBox):
    """`page`: the Setup page (its state, `start` and status line). `connecting`: emitted
    before the port is opened for a connection."""

    connecting = Signal()

    def __init__(self, page, parent: QWidget | None = None):
        super().__init__("Robot connection", parent)
        self.page = page
        self.state = page.state
        self.joints: np.ndarray | None = None       # last read (internal units)

        self.virtual_radio = QRadioButton("Virtual lab (simulated robot)")
        self.virtual_radio.setObjectName("virtualRobotRadio")
        self.serial_radio = QRadioButton("Serial robot")
        self.serial_radio.setObjectName("serialRobotRadio")
        group = QButtonGroup(self)
        group.addButton(self.virtual_radio)
        group.addButton(self.serial_radio)
        self.virtual_radio.setChecked(True)
        self.virtual_radio.toggled.connect(self._kind_toggled)

        self.serial_form = SerialForm()
        form = self.serial_form       # its fields, as the protocol panel and the tests reach them
        self.port_edit, self.profile_combo, self.baud_combo = form.port_edit, form.profile_combo, form.baud_combo
        self.joint_map_edit, self.speed_spin = form.joint_map_edit, form.speed_spin
        self.connect_button, self.disconnect_button = form.connect_button, form.disconnect_button
        self.connect_button.clicked.connect(lambda *_: self.connect_robot())
        self.disconnect_button.clicked.connect(lambda *_: self.disconnect_robot())
        test = self._build_test()

        layout = QVBoxLayout(self)
        layout.addWidget(self.virtual_radio)
        layout.addWidget(self.serial_radio)
        layout.addWidget(self.serial_form)
        self.simulator_row = SimulatorRow(page, self)
        layout.addWidget(self.simulator_row)
        layout.addLayout(test)

        self.state.hardware.connectionChanged.connect(self.refresh)
        self.state.robotChanged.connect(self._robot_changed)
        self.state.projectChanged.connect(self.restore)
        self.state.hardware.stoppedChanged.connect(self.refresh)
        self._robot_changed()

    def _build_test(self) -> QVBoxLayout:
        """The controller's identity, joints read, a one-joint test move, Stop and Resume."""
        self.info_label = QLabel()
        self.info_label.setObjectName("robotInfo")
        self.info_label.setWordWrap(True)
        self.joints_label = QLabel()
        self.joints_label.setObjectName("jointsLabel")
        self.joints_label.setWordWrap(True)
        self.read_button = forms.button("Read joints", "readJointsButton", on_click=self.read_joints)
        self.joint_combo = QComboBox()
        self.joint_combo.setObjectName("jogJoint")
        self.joint_combo.currentIndexChanged.connect(self._show_limits)
        self.step_spin = forms.double_spin(2.0, 0.1, 10.0, decimals=1, step=0.5, name="jogStep", suffix=" °",
                                           tooltip="Size of one jog step (degrees, or mm for a sliding joint)")
        self.jog_minus = forms.button("Jog −", "jogMinusButton", on_click=lambda: self.jog(-1))
        self.jog_plus = forms.button("Jog +", "jogPlusButton", on_click=lambda: self.jog(+1))
        self.stop_button = forms.button("Stop", "panelStopButton", on_click=self.stop_robot,
                                        tooltip="Stop the robot now (Esc)")
        self.stop_button.setStyleSheet("QPushButton { color: white; background: #c5221f; font-weight: 600; }")
        self.resume_button = forms.button("Resume", "panelResumeButton", on_click=self.resume_robot,
                                          tooltip="Accept motion again once the way is clear")
        self.limits_label = QLabel()
        self.limits_label.setObjectName("hint")
        self.limits_label.setWordWrap(True)
        test = QVBoxLayout()
        test.addWidget(self.info_label)
        test.addLayout(forms.row(self.read_button, self.joints_label, stretch=False))
        test.addLayout(forms.row("Test move:", self.joint_combo, self.step_spin, self.jog_minus, self.jog_plus))
        test.addLayout(forms.row(self.stop_button, self.resume_button))
        test.addWidget(self.limits_label)
        return test

    # -- choices -------------------------------------------------------------------------
    def choice(self) -> RobotChoice:
        """The serial robot chosen in the form."""
        return self.serial_form.options()

    def restore(self, project) -> None:
        """Fill the fields with the serial robot the project recorded (not connected yet)."""
        saved = project.robot_connection if project is not None else None
        if saved is None or saved.kind != SERIAL:
            return
        self.serial_form.show_options(saved)
        self.serial_radio.setChecked(True)

    def _kind_toggled(self, virtual: bool) -> None:
        if virtual and self.state.hardware.robot_choice.real:
            self.state.hardware.use_virtual_robot()
            self.joints = None
        self.refresh()

    # -- actions (tests call them) -------------------------------------------------------
    def connect_robot(self) -> bool:
        if self.state.robot is None:
            self.page._set_status("Choose the robot model first: its joint limits guard every motion.", False)
            return False
        self.serial_radio.setChecked(True)
        choice = self.choice()
        self.connecting.emit()
        return self.page.task.start(connect_serial, self.state.robot, choice, self.serial_form.speed(),
                               on_done=lambda c: self._connected(c, choice), label="Connecting the robot",
                               status=f"Connecting to {choice.port or '(no port)'}…")

    def _connected(self, c: Connected, choice: RobotChoice) -> None:
        self.state.hardware.use_serial_robot(c.driver, choice)
        self.joints = c.joints
        self.page._set_status(f"✓ Connected: {c.info.name}, {c.info.dof} joints.", True)
        self.refresh()

    def disconnect_robot(self) -> None:
        self.state.hardware.use_virtual_robot()
        self.virtual_radio.setChecked(True)
        self.joints = None
        self.refresh()

    def read_joints(self) -> bool:
        driver = self.state.hardware.robot_connection
        if driver is None:
            self.page._set_status("No robot connected.", False)
            return False
        return self.page.task.start(read_joints, driver, on_done=self._joints_read, label="Reading the joints")

    def read_again(self) -> bool:
        """The joints shown were read before another step moved the robot: forget them (a jog
        never starts from an old reading) and read them again when the robot is connected."""
        if self.joints is None:
            return False
        self.joints = None
        self.refresh()
        driver = self.state.hardware.robot_connection
        if driver is None or not driver.connected or self.page.task.busy:
            return False
        return self.read_joints()

    def _joints_read(self, q) -> None:
        self.joints = np.asarray(q, dtype=float)
        self.page._set_status("Joints read.", True)
        self.refresh()

    def jog_target(self, direction: int) -> np.ndarray | None:
        """The last read joints with the chosen joint moved one step (internal units)."""
        model = self.state.robot
        if model is None or self.joints is None:
            return None
        j = max(self.joint_combo.currentIndex(), 0)
        step = self.step_spin.value()
        q = self.joints.copy()
        q[j] += direction * (np.deg2rad(step) if model.joints[j].revolute else step)
        return q

    def jog(self, direction: int) -> bool:
        """Move the chosen joint one step: refused outside its limits (the joint and its limits
        shown), the first motion of a real robot confirmed, after a stop only once resumed."""
        target = self.jog_target(direction)
        if target is None:
            self.page._set_status("Read the joints first.", False)
            return False
        refused = motion_refused(self, self.state, [target])
        if refused:
            self.page._set_status(refused, False)
            return False
        return self.page.task.start(move_and_read, self.state.hardware.robot_connection, target, on_done=self._joints_read,
                               label="Test move", status="Moving… (Esc stops)")

    def stop_robot(self) -> None:
        if self.state.hardware.stop_robot():
            self.page._set_status("Robot stopped. Resume when the way is clear.", False)

    def resume_robot(self) -> None:
        try:
            self.state.hardware.resume_robot()
        except RoboCalError as exc:                       # a controller refusing to unlock
            self.page._set_status(f"Cannot resume: {exc.message}", False)
            return
        self.page._set_status("Robot ready.", True)

    # -- display -------------------------------------------------------------------------
    def _robot_changed(self, *_) -> None:
        model = self.state.robot
        self.joint_combo.blockSignals(True)
        self.joint_combo.clear()
        for i, joint in enumerate(model.joints if model is not None else ()):
            self.joint_combo.addItem(joint.name or f"J{i + 1}")
        self.joint_combo.blockSignals(False)
        if self.state.hardware.robot_connection is None or not self.state.hardware.real_robot:
            self.joints = None
        self.refresh()

    def _show_limits(self, *_) -> None:
        model = self.state.robot
        j = self.joint_combo.currentIndex()
        if model is None or j < 0:
            self.limits_label.setText("")
            return
        lo, hi = (model.q_to_file(v)[j] for v in model.limits())
        unit = "°" if model.joints[j].revolute else " mm"
        now = f", now {model.q_to_file(self.joints)[j]:.2f}{unit}" if self.joints is not None else ""
        self.limits_label.setText(f"{self.joint_combo.currentText()}: limits {lo:.1f}{unit} … {hi:.1f}{unit}{now}. "
                                  "A move outside them is refused before anything is sent.")

    def refresh(self, *_) -> None:
        state = self.state
        driver = state.hardware.robot_connection
        serial = self.serial_radio.isChecked()
        self.serial_form.setEnabled(serial)
        busy = self.page.task.busy
        connected = driver is not None and driver.connected
        real = state.hardware.real_robot
        waiting = serial and not real           # Serial chosen, no serial robot connected (yet)
        self.connect_button.setEnabled(serial and not busy)
        self.disconnect_button.setEnabled(real and not busy)
        if waiting:
            self.info_label.setText("<b>Serial robot: not connected.</b> Give the port (or start the simulator "
                                    "below) and press Connect.")
        elif driver is None:
            self.info_label.setText("Choose a robot model to connect the simulated robot.")
        else:
            info = driver.info
            name = getattr(driver, "controller_name", "") or info.name
            where = esc(driver.name)
            self.info_label.setText(
                f"<b>{esc(name)}</b> · {info.dof} joints · controller units {esc(info.units)} · "
                f"speed {driver.speed:g} % · {where}: {'connected' if connected else 'not connected'}"
                + (" · <b style='color:#c5221f'>stopped</b>" if driver.stopped else ""))
        if self.joints is not None and state.robot is not None:
            values = state.robot.q_to_file(self.joints)
            self.joints_label.setText("Joints: " + "  ".join(f"{v:.2f}" for v in values))
        else:
            self.joints_label.setText("")
        can_move = connected and not busy and not waiting
        self.read_button.setEnabled(can_move)
        self.jog_minus.setEnabled(can_move and self.joints is not None)
        self.jog_plus.setEnabled(can_move and self.joints is not None)
        self.stop_button.setEnabled(driver is not None)
        self.resume_button.setEnabled(driver is not None and driver.stopped and not busy)
        self._show_limits()
