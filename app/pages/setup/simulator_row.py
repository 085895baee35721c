"""The Setup page's classroom simulator: without a robot, start the controller simulator
(what `robocal sim-robot` serves: the virtual lab's robot for a seed, RoboCal protocol v1 or
GRBL, realistic motion time, no faults) on a pseudo-terminal inside RoboCal. Its device path
fills the port field; it stops with the project or when RoboCal closes (WizardState)."""
from __future__ import annotations

from PySide6.QtCore import Qt
from PySide6.QtWidgets import QComboBox, QLabel, QWidget

from app.lab import build_lab
from app.pages import forms
from core.robot.controller_sim import ControllerSim
from widgets.flow_layout import FlowLayout

PROFILES = {"robocal": "robocal_v1", "grbl": "grbl_joint_arm"}    # simulator protocol -> profile


def start_simulator(model, protocol: str, seed: int, noise: float) -> ControllerSim:
    """Worker: the virtual lab's true robot for `model` and `seed`, served on a new pty."""
    lab = build_lab(model, seed, noise)
    return ControllerSim(lab.true_robot, protocol=protocol, seed=seed).start()


class SimulatorRow(QWidget):
    """`page`: the Setup page; `robot`: its RobotPanel (port and protocol fields)."""

    def __init__(self, page, robot, parent: QWidget | None = None):
        super().__init__(parent)
        self.page, self.robot, self.state = page, robot, page.state
        self.protocol_combo = QComboBox()
        self.protocol_combo.setObjectName("simProtocolCombo")
        self.protocol_combo.addItem("RoboCal protocol v1", "robocal")
        self.protocol_combo.addItem("GRBL joint arm", "grbl")
        self.seed_spin = forms.spin(int(self.state.seed), 0, 2 ** 31 - 1, name="simSeedSpin",
                                    tooltip="The virtual lab seed: the same seed gives the same robot and cameras")
        self.start_button = forms.button("Start simulator", "simStartButton", on_click=self.start,
                                         tooltip="A simulated controller on a serial device of this computer, "
                                                 "for a class without a robot")
        self.stop_button = forms.button("Stop simulator", "simStopButton", on_click=self.stop)
        self.device_label = QLabel()
        self.device_label.setObjectName("simDevice")
        self.device_label.setTextInteractionFlags(Qt.TextInteractionFlag.TextSelectableByMouse)
        layout = FlowLayout()            # wraps on a narrow window
        layout.add_group(QLabel("No robot? Simulator:"), self.protocol_combo)
        layout.add_group(QLabel("seed"), self.seed_spin)
        for w in (self.start_button, self.stop_button, self.device_label):
            layout.addWidget(w)
        layout.setContentsMargins(18, 0, 0, 0)
        self.setLayout(layout)
        self.state.hardware.simulatorChanged.connect(self.refresh)
        self.refresh()

    def start(self) -> bool:
        if self.state.robot is None:
            self.page._set_status("Choose the robot model first: the simulator serves that robot.", False)
            return False
        protocol = self.protocol_combo.currentData()
        return self.page.task.start(start_simulator, self.state.robot, protocol, int(self.seed_spin.value()),
                               float(self.state.noise), on_done=lambda sim: self._started(sim, protocol),
                               label="Starting the simulator", status="Starting the controller simulator…")

    def _started(self, sim: ControllerSim, protocol: str) -> None:
        self.state.hardware.set_simulator(sim)
        self.robot.serial_radio.setChecked(True)
        self.robot.port_edit.setText(sim.port)
        self.robot.profile_combo.setCurrentText(PROFILES[protocol])
        self.page._set_status(f"✓ Simulator serving on {sim.port}. Press Connect.", True)

    def stop(self) -> None:
        self.state.hardware.set_simulator(None)

    def refresh(self, *_) -> None:
        sim = self.state.hardware.simulator
        busy = self.page.task.busy
        self.start_button.setEnabled(sim is None and not busy)
        self.stop_button.setEnabled(sim is not None)
        self.protocol_combo.setEnabled(sim is None)
        self.seed_spin.setEnabled(sim is None)
        self.device_label.setText(f"serving on <b>{sim.port}</b>" if sim is not None else "")
