"""The Measurement page's teach-mode panel: the next pose to bring the robot to (its joint values
beside the limits, and the nominal arm in that pose seen from above and from the side, in the
robot's base frame), where the joint values come from (read from the controller, or typed or
pasted from the pendant: `options()`), what the check found, and Record pose."""
from __future__ import annotations

from typing import Callable

import numpy as np
from PySide6.QtCore import Qt
from PySide6.QtWidgets import QCheckBox, QGridLayout, QLabel, QLineEdit, QVBoxLayout, QWidget

from app.html import esc
from app.pages.forms import button, row
from app.pages.measurement.model import JointSource
from app.pages.measurement.texts import WARN
from widgets.workspace_views import OrthoView

OK = "#188038"
BAD = "#c5221f"


def pose_html(pose: int, place: str, model, planned_file) -> str:
    """The pose's number and a table, one column per joint: the planned value and the limits
    (deg / mm)."""
    lo, hi = (model.q_to_file(v) for v in model.limits())
    units = ["°" if j.revolute else " mm" for j in model.joints]
    names = "".join(f"<th align='right'>&nbsp;&nbsp;{esc(j.name or f'J{i + 1}')}</th>"
                    for i, j in enumerate(model.joints))
    planned = "".join(f"<td align='right'>&nbsp;&nbsp;<b>{v:.2f}{u}</b></td>" for v, u in zip(planned_file, units))
    limits = "".join(f"<td align='right'>&nbsp;&nbsp;{a:.0f} … {b:.0f}</td>" for a, b in zip(lo, hi))
    return (f"<b>Next pose: {pose}</b> ({esc(place)})<table cellspacing='0' cellpadding='1'>"
            f"<tr><td></td>{names}</tr><tr><td>Planned</td>{planned}</tr><tr><td>Limits</td>{limits}</tr></table>")


class TeachPanel(QWidget):
    """Teach mode: `on_record()` records the pose shown; `on_typed(text)` checks typed values
    as they change; `on_use_plan()` copies the planned values into the field."""

    def __init__(self, *, on_record: Callable, on_typed: Callable[[str], None], on_use_plan: Callable,
                 parent: QWidget | None = None):
        super().__init__(parent)
        self.pose_label = QLabel()
        self.pose_label.setObjectName("teachPoseLabel")
        self.pose_label.setTextFormat(Qt.TextFormat.RichText)
        self.pose_label.setAlignment(Qt.AlignmentFlag.AlignTop | Qt.AlignmentFlag.AlignLeft)
        self.how = QLabel("Bring the robot to this pose with its own pendant (or by hand), wait until it is "
                          "still, then Record pose: both cameras capture and the marker is located.")
        self.how.setObjectName("hint")
        self.how.setWordWrap(True)
        self.read_check = QCheckBox("Read the joint values from the controller")
        self.read_check.setObjectName("readJointsCheck")
        self.read_check.setToolTip("When the connected controller reports its joints, RoboCal reads them "
                                   "at the moment of the capture")
        self.read_check.toggled.connect(lambda on: self.joints_edit.setEnabled(not on))
        self.joints_edit = QLineEdit()
        self.joints_edit.setObjectName("jointsEdit")
        self.joints_edit.setPlaceholderText("The joint values the pendant shows, J1 first: degrees (mm for "
                                            "sliding joints), separated by spaces, commas or tabs")
        self.joints_edit.textChanged.connect(on_typed)
        self.joints_edit.returnPressed.connect(on_record)
        self.plan_button = button("Use the planned values", "usePlanButton", on_click=on_use_plan,
                                  tooltip="Copy the planned values into the field, then correct them to what "
                                          "the pendant shows")
        self.check_label = QLabel()
        self.check_label.setObjectName("teachCheckLabel")
        self.check_label.setWordWrap(True)
        self.check_label.setTextFormat(Qt.TextFormat.RichText)
        self.record_button = button("Record pose", "recordPoseButton", on_click=on_record,
                                    tooltip="Capture both cameras now, locate the marker and write the pose")
        self.top = OrthoView("x", "y", "From above (robot base)")
        self.side = OrthoView("x", "z", "From the side (robot base)")
        for view in (self.top, self.side):
            view.setMinimumSize(160, 150)

        form = QVBoxLayout()
        form.setSpacing(4)
        form.addWidget(self.pose_label)
        form.addWidget(self.how)
        form.addWidget(self.read_check)
        form.addLayout(row(QLabel("Joint values:"), self.joints_edit, self.plan_button, stretch=False))
        form.addWidget(self.check_label)
        form.addLayout(row(self.record_button))
        form.addStretch(1)
        grid = QGridLayout(self)
        grid.setContentsMargins(0, 0, 0, 0)
        grid.setHorizontalSpacing(8)
        grid.addLayout(form, 0, 0)
        grid.addWidget(self.top, 0, 1)
        grid.addWidget(self.side, 0, 2)
        grid.setColumnStretch(0, 5)
        grid.setColumnStretch(1, 3)
        grid.setColumnStretch(2, 3)

    def options(self) -> JointSource:
        return JointSource(read_from_controller=self.read_check.isChecked(), typed=self.joints_edit.text())

    def show_options(self, source: JointSource) -> None:
        """Tick Read the joint values, and put `source.typed` in the field (each only when it changes)."""
        if source.read_from_controller != self.read_check.isChecked():
            self.read_check.setChecked(source.read_from_controller)
        if source.typed != self.joints_edit.text():
            self.joints_edit.setText(source.typed)

    def show_pose(self, html: str, arm) -> None:
        """The next pose (`pose_html`) and the nominal arm in it ((P, 3) mm, base frame; None: none)."""
        self.pose_label.setText(html)
        for view in (self.top, self.side):
            view.set_arm(arm)
            if arm is not None:
                reach = float(np.max(np.linalg.norm(arm, axis=1)))
                view.fit(np.vstack([arm, [[reach, reach, reach], [-reach, -reach, 0.0]]]))

    def show_check(self, lines: list[tuple[str, str]]) -> None:
        """(kind, text) lines: kind "ok", "warn" or "bad"."""
        colours = {"ok": OK, "warn": WARN, "bad": BAD}
        self.check_label.setText("<br>".join(f"<span style='color:{colours[k]}'>{esc(t)}</span>" for k, t in lines))

    def set_enabled(self, *, busy: bool, can_read: bool, has_pose: bool) -> None:
        self.read_check.setEnabled(can_read and not busy)
        if not can_read:
            self.read_check.setChecked(False)
        self.joints_edit.setEnabled(not busy and not self.read_check.isChecked())
        self.plan_button.setEnabled(not busy and has_pose)
        self.record_button.setEnabled(not busy and has_pose)
