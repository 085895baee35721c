"""The Check page's controls: the check poses, "Run check now", the schedule, and on the virtual
lab the change to simulate."""
from __future__ import annotations

import numpy as np
from PySide6.QtWidgets import (QCheckBox, QComboBox, QGroupBox, QLabel, QListWidget, QVBoxLayout, QWidget)

from app.pages import forms

#: (label, change kind) of the "Simulate a change" choice
CHANGES = [("none", ""), ("tool offset (mm)", "tool"), ("base shift (mm)", "base"),
           ("joint zero slip (°)", "joint"), ("link bent (mm)", "link")]


class CheckControls(QWidget):
    def __init__(self, parent=None):
        super().__init__(parent)
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
        run_box = QGroupBox("Checks")
        rl = QVBoxLayout(run_box)
        rl.addWidget(self.run_button)
        rl.addLayout(forms.row(self.schedule_check, self.minutes_spin))

        self.change_combo = QComboBox()
        self.change_combo.setObjectName("changeCombo")
        for label, _ in CHANGES:
            self.change_combo.addItem(label)
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
        self.change_combo.currentIndexChanged.connect(lambda *_: self._change_kind_changed())
        self._change_kind_changed()

        layout = QVBoxLayout(self)
        layout.setContentsMargins(0, 0, 0, 0)
        layout.addWidget(poses_box)
        layout.addWidget(run_box)
        layout.addWidget(self.change_box)
        layout.addStretch(1)

    def _change_kind_changed(self) -> None:
        kind = CHANGES[self.change_combo.currentIndex()][1]
        self.joint_spin.setEnabled(kind in ("joint", "link"))
        self.size_spin.setEnabled(bool(kind))

    def set_dof(self, dof: int) -> None:
        self.joint_spin.setMaximum(max(1, dof))

    def change_spec(self) -> str | None:
        """The chosen change as the lab reads it (tool:1.5, joint3:0.4, …), or None."""
        kind = CHANGES[self.change_combo.currentIndex()][1]
        if not kind:
            return None
        size = self.size_spin.value()
        if kind in ("tool", "base"):
            size = abs(size)
        number = self.joint_spin.value() if kind in ("joint", "link") else ""
        return f"{kind}{number}:{size:g}"

    def choose_change(self, kind: str, size: float, joint: int = 1) -> None:
        """Select a change (for the autopilot and tests): kind '' (none), tool, base, joint or link."""
        self.change_combo.setCurrentIndex([k for _, k in CHANGES].index(kind))
        self.size_spin.setValue(size)
        self.joint_spin.setValue(joint)

    def show_poses(self, Q_deg) -> None:
        """List the check poses (joint values in degrees / mm)."""
        self.poses_list.clear()
        for k, q in enumerate(np.asarray(Q_deg, dtype=float)):
            self.poses_list.addItem(f"pose {k}: " + ", ".join(f"{v:.1f}" for v in q))

    def set_enabled(self, busy: bool, ready: bool, virtual: bool) -> None:
        for w in (self.choose_button, self.run_button, self.count_spin):
            w.setEnabled(ready and not busy)
        self.change_box.setEnabled(virtual and not busy)
