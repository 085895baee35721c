"""The Check page's controls: the tool mounted (a robot with several tools), the check poses, "Run
check now", the schedule, and on the virtual lab (only) the change to simulate. What is chosen is
read as the model's options (`options()`, `show_options(o)`; `optionsChanged` on every change);
the check poses are drawn from the model's events (`follow(model)`)."""
from __future__ import annotations

import numpy as np
from PySide6.QtCore import Signal
from PySide6.QtWidgets import (QCheckBox, QComboBox, QGroupBox, QLabel, QListWidget, QVBoxLayout, QWidget)

from app.pages import forms
from app.pages.check.model import CheckModel, CheckOptions

#: (label, change kind) of the "Simulate a change" choice
CHANGES = [("none", ""), ("tool offset (mm)", "tool"), ("base shift (mm)", "base"),
           ("joint zero slip (°)", "joint"), ("link bent (mm)", "link")]
SCHEDULE_TIP = "Run a check on its own every so many minutes while RoboCal is open; each is logged"
#: the change offered when the robot has several tools: another tool mounted than the one checked
MOUNT = ("another tool mounted", "mount")


class CheckControls(QWidget):
    optionsChanged = Signal()          # anything `options()` returns may have changed

    def __init__(self, parent=None):
        super().__init__(parent)
        self._changes = list(CHANGES)
        self.tool_combo = QComboBox()
        self.tool_combo.setObjectName("toolCombo")
        self.tool_combo.setToolTip("The tool on the robot now: check poses, predictions and limits use its marker")
        self.identify_tool_button = forms.button(
            "Identify this tool", "identifyToolButton",
            tooltip="Measure the mounted tool's marker at a few proposed poses and identify its offset on the "
                    "calibrated arm (needed once for a tool the calibration did not measure)")
        self.tool_box = QGroupBox("Tool mounted")
        tl = QVBoxLayout(self.tool_box)
        tl.addWidget(self.tool_combo)
        tl.addWidget(self.identify_tool_button)
        self.payload_check = QCheckBox("Payload now")
        self.payload_check.setToolTip("Say the mass on the flange now: each check compares it with the payload "
                                      "the calibration was measured with")
        self.payload_spin = forms.double_spin(0.0, 0.0, 5000.0, decimals=2, step=0.5, name="payloadSpin",
                                              suffix=" kg")
        self.payload_spin.setEnabled(False)
        self.payload_check.toggled.connect(self.payload_spin.setEnabled)
        tl.addLayout(forms.row(self.payload_check, self.payload_spin))
        self.count_spin = forms.spin(8, 3, 20, name="checkPoseCount", suffix=" poses",
                                     tooltip="How many check poses to choose (by observability of the marker, "
                                             "base and joint zero offsets)")
        self.choose_button = forms.button("Choose check poses", "choosePosesButton")
        self.poses_list = QListWidget()
        self.poses_list.setObjectName("checkPosesList")
        self.poses_list.setMaximumHeight(150)
        poses_box = QGroupBox("Check poses")
        pl = QVBoxLayout(poses_box)
        pl.addLayout(forms.row(self.count_spin, self.choose_button))
        self.poses_note = QLabel("Joint values q1 … qn (° or mm), chosen with the first check.")
        self.poses_note.setWordWrap(True)
        pl.addWidget(self.poses_note)
        pl.addWidget(self.poses_list)

        self.run_button = forms.button("Run check now", "runCheckButton",
                                       tooltip="Measure the marker at every check pose and compare it with the "
                                               "calibrated model's prediction")
        self.run_button.setDefault(True)
        self.schedule_check = QCheckBox("Check every")
        self.schedule_check.setObjectName("scheduleCheck")
        self.minutes_spin = forms.spin(10, 1, 24 * 60, name="scheduleMinutes", suffix=" min")
        self.allow_schedule(None, False)
        self.cell_label = QLabel()
        self.cell_label.setObjectName("checkCell")
        self.cell_label.setWordWrap(True)
        run_box = QGroupBox("Checks")
        rl = QVBoxLayout(run_box)
        rl.addWidget(self.cell_label)
        rl.addWidget(self.run_button)
        rl.addLayout(forms.row(self.schedule_check, self.minutes_spin))

        self.change_combo = QComboBox()
        self.change_combo.setObjectName("changeCombo")
        for label, _ in self._changes:
            self.change_combo.addItem(label)
        self.mount_combo = QComboBox()
        self.mount_combo.setObjectName("mountCombo")
        self.mount_combo.setToolTip("The tool the lab's robot carries instead")
        self.joint_spin = forms.spin(1, 1, 6, name="changeJoint", tooltip="Which joint (or link)")
        self.joint_spin.setPrefix("joint ")
        self.size_spin = forms.double_spin(1.5, -50.0, 50.0, decimals=2, step=0.1, name="changeSize",
                                           tooltip="Size of the change: mm (tool, base, link) or degrees (joint)")
        self.change_box = QGroupBox("Simulate a change (virtual lab)")
        cl = QVBoxLayout(self.change_box)
        note = QLabel("The lab's robot changes as it would after a tool swap, a bumped stand, a slipped "
                      "encoder or a bent link. Every check sees the change until you choose none.")
        note.setWordWrap(True)
        cl.addWidget(note)
        cl.addWidget(self.change_combo)
        cl.addLayout(forms.row(self.joint_spin, self.size_spin))
        cl.addWidget(self.mount_combo)
        self.change_combo.currentIndexChanged.connect(lambda *_: self._change_kind_changed())
        self._change_kind_changed()
        self.tool_box.setVisible(False)

        layout = QVBoxLayout(self)
        layout.setContentsMargins(0, 0, 0, 0)
        layout.addWidget(self.tool_box)
        layout.addWidget(poses_box)
        layout.addWidget(run_box)
        layout.addWidget(self.change_box)
        layout.addStretch(1)
        for changed in (self.count_spin.valueChanged, self.tool_combo.currentIndexChanged,
                        self.change_combo.currentIndexChanged, self.mount_combo.currentIndexChanged,
                        self.joint_spin.valueChanged, self.size_spin.valueChanged, self.payload_check.toggled,
                        self.payload_spin.valueChanged, self.schedule_check.toggled, self.minutes_spin.valueChanged):
            changed.connect(lambda *_: self.optionsChanged.emit())

    def options(self) -> CheckOptions:
        """What is chosen: pose count, tool mounted, change simulated, payload, schedule."""
        return CheckOptions(count=self.count_spin.value(), tool=self.tool(), change=self.change_spec(),
                            payload_kg=self.payload_kg(),
                            schedule_minutes=self.minutes_spin.value() if self.schedule_check.isChecked() else None)

    def show_options(self, options: CheckOptions) -> None:
        """Show `options` as chosen (its change as `change_spec()` writes it)."""
        self.count_spin.setValue(options.count)
        if options.tool is not None:
            self.choose_tool(options.tool)
        kind, _, value = (options.change or "").partition(":")
        if kind == "mount":
            self.choose_change("mount", self.size_spin.value(), tool=value)
        else:
            name = kind.rstrip("0123456789")
            self.choose_change(name, float(value) if value else self.size_spin.value(),
                               int(kind[len(name):] or self.joint_spin.value()))
        self.payload_check.setChecked(options.payload_kg is not None)
        if options.payload_kg is not None:
            self.payload_spin.setValue(options.payload_kg)
        if options.schedule_minutes is not None:
            self.minutes_spin.setValue(options.schedule_minutes)
        self.schedule_check.setChecked(options.schedule_minutes is not None)

    def follow(self, model: CheckModel) -> None:
        """List the check poses when chosen, none when the calibration changed."""
        model.on("poses", lambda outcome: self.show_poses(outcome.cell.model.q_to_file(outcome.cell.Q)))
        model.on("cleared", lambda _: self.poses_list.clear())

    def _change_kind_changed(self) -> None:
        kind = self._changes[self.change_combo.currentIndex()][1]
        self.joint_spin.setEnabled(kind in ("joint", "link"))
        self.size_spin.setEnabled(bool(kind) and kind != "mount")
        self.mount_combo.setVisible(kind == "mount")

    def set_tools(self, names) -> None:
        """The robot's tools: the selector (and the "another tool mounted" change) only for several."""
        names = list(names)
        if names == [self.tool_combo.itemText(i) for i in range(self.tool_combo.count())]:
            return
        for combo in (self.tool_combo, self.mount_combo):
            combo.blockSignals(True)
            combo.clear()
            combo.addItems(names)
            combo.blockSignals(False)
        self.tool_box.setVisible(len(names) > 1)
        changes = list(CHANGES) + ([MOUNT] if len(names) > 1 else [])
        if changes != self._changes:
            self._changes = changes
            self.change_combo.blockSignals(True)
            self.change_combo.clear()
            self.change_combo.addItems([label for label, _ in changes])
            self.change_combo.blockSignals(False)
        self._change_kind_changed()
        self.optionsChanged.emit()

    def payload_kg(self) -> float | None:
        """The payload mounted now (kg), or None when not said."""
        return float(self.payload_spin.value()) if self.payload_check.isChecked() else None

    def tool(self) -> str | None:
        """The tool chosen as mounted; None for a robot with one tool."""
        return self.tool_combo.currentText() if self.tool_combo.count() > 1 else None

    def choose_tool(self, name: str) -> None:
        self.tool_combo.setCurrentText(name)

    def set_dof(self, dof: int) -> None:
        self.joint_spin.setMaximum(max(1, dof))

    def change_spec(self) -> str | None:
        """The chosen change as the lab reads it (tool:1.5, joint3:0.4, …), or None."""
        kind = self._changes[self.change_combo.currentIndex()][1]
        if not kind:
            return None
        if kind == "mount":
            return f"mount:{self.mount_combo.currentText()}"
        size = self.size_spin.value()
        if kind in ("tool", "base"):
            size = abs(size)
        number = self.joint_spin.value() if kind in ("joint", "link") else ""
        return f"{kind}{number}:{size:g}"

    def choose_change(self, kind: str, size: float, joint: int = 1, tool: str = "") -> None:
        """Select a change (for the autopilot and tests): kind '' (none), tool, base, joint, link, or
        mount (the robot's `tool` mounted instead)."""
        self.change_combo.setCurrentIndex([k for _, k in self._changes].index(kind))
        if tool:
            self.mount_combo.setCurrentText(tool)
        self.size_spin.setValue(size)
        self.joint_spin.setValue(joint)

    def show_cell(self, words: str) -> None:
        """Where the checks measure (the project's cell), in words."""
        self.cell_label.setText(f"Measures on {words}.")

    def show_poses(self, Q_deg) -> None:
        """List the check poses (joint values in degrees / mm)."""
        self.poses_list.clear()
        for k, q in enumerate(np.asarray(Q_deg, dtype=float)):
            self.poses_list.addItem(f"pose {k}: " + ", ".join(f"{v:.1f}" for v in q))

    def allow_schedule(self, blocked: str | None, busy: bool) -> None:
        """"Check every N min" only where checks can run (`blocked`: why they cannot, said in the
        tooltip; a schedule that was on is switched off). Not changed while a check runs."""
        for w in (self.schedule_check, self.minutes_spin):
            w.setEnabled(blocked is None and not busy)
            w.setToolTip(SCHEDULE_TIP if blocked is None else f"Checks cannot run on a schedule: {blocked}.")
        if blocked is not None and self.schedule_check.isChecked():
            self.schedule_check.setChecked(False)

    def set_enabled(self, busy: bool, ready: bool, virtual: bool) -> None:
        for w in (self.choose_button, self.run_button, self.count_spin, self.tool_combo):
            w.setEnabled(ready and not busy)
        self.identify_tool_button.setEnabled(ready and not busy)
        self.change_box.setEnabled(virtual and not busy)
        self.change_box.setVisible(virtual)        # a real cell changes by itself, never by simulation
