"""The Check page's teach mode, for a real cell whose robot RoboCal does not drive: the next check
pose to bring the robot to, its joints typed from the pendant (° / mm), Record pose (capture and
locate), and the check of the recorded poses once every one is recorded."""
from __future__ import annotations

import numpy as np
from PySide6.QtWidgets import QGroupBox, QLabel, QLineEdit, QVBoxLayout

from app.html import esc
from app.pages import forms


class TeachCheckPanel(QGroupBox):
    def __init__(self, parent=None):
        super().__init__("Teach mode: record each check pose", parent)
        self.next_label = QLabel()
        self.next_label.setObjectName("teachNextPose")
        self.next_label.setWordWrap(True)
        self.joints_edit = QLineEdit()
        self.joints_edit.setObjectName("teachJointsEdit")
        self.joints_edit.setPlaceholderText("the joints the pendant shows, J1 first (° or mm); empty: read them")
        self.record_button = forms.button("Record pose", "teachRecordButton",
                                          tooltip="Capture a pair from the cameras where the robot is now and "
                                                  "locate the marker")
        self.check_button = forms.button("Check the recorded poses", "teachCheckButton",
                                         tooltip="Judge the recorded poses against their limits and log them")
        layout = QVBoxLayout(self)
        layout.addWidget(self.next_label)
        layout.addWidget(self.joints_edit)
        layout.addLayout(forms.row(self.record_button, self.check_button))

    def show_next(self, index: int | None, q_file, recorded: int, total: int) -> None:
        """The pose to bring the robot to (None: every pose recorded)."""
        if index is None:
            self.next_label.setText(f"All {total} check poses recorded: check them.")
            return
        values = ", ".join(f"{v:.1f}" for v in np.asarray(q_file, dtype=float))
        self.next_label.setText(f"{recorded} of {total} recorded. Bring the robot to <b>pose {index}</b>: "
                                f"{esc(values)}, type the joints it reached, then Record pose.")
