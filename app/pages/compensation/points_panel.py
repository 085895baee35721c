"""The Compensation page's Points panel: type a point (robot base frame, camera frame, or the
fixture located on the Check page) or load a joint program taught with the nominal model; Go to
point and writing the corrected program act on what is listed in the table."""
from __future__ import annotations

from pathlib import Path
from typing import Callable

from PySide6.QtCore import Signal
from PySide6.QtWidgets import QCheckBox, QComboBox, QFileDialog, QGroupBox, QLabel, QVBoxLayout

from app.jobs.compensation import PROGRAM_NAME
from app.pages import forms
from app.pages.compensation.model import FRAMES, PointOptions
from widgets.flow_layout import FlowLayout

FRAME_LABELS = ["robot base frame", "camera frame (left camera)", "located fixture (fixture_pose.json)"]


class PointsPanel(QGroupBox):
    """Signals: `programChosen(path)` and `outputChosen(path)`: the file dialogs' answers, which
    open in the project's folder `folder()` (None: no project)."""

    programChosen = Signal(str)
    outputChosen = Signal(str)

    def __init__(self, folder: Callable[[], Path | None] = lambda: None, parent=None):
        super().__init__("Points", parent)
        self._folder = folder
        note = QLabel("Type a point where the marker should go, or load a program (targets, or joints taught "
                      "with the nominal model): RoboCal computes the joints that put the calibrated robot there.")
        note.setWordWrap(True)
        self.x_spin = forms.double_spin(0.0, -5000.0, 5000.0, decimals=2, step=1.0, name="pointX", suffix=" mm")
        self.y_spin = forms.double_spin(0.0, -5000.0, 5000.0, decimals=2, step=1.0, name="pointY", suffix=" mm")
        self.z_spin = forms.double_spin(0.0, -5000.0, 5000.0, decimals=2, step=1.0, name="pointZ", suffix=" mm")
        self.frame_combo = QComboBox()
        self.frame_combo.setObjectName("pointFrame")
        for label in FRAME_LABELS:
            self.frame_combo.addItem(label)
        self.add_button = forms.button("Add point", "addPointButton",
                                       tooltip="Compute the nominal and the corrected joints of this point")
        self.load_button = forms.button("Load program…", "loadProgramButton",
                                        tooltip="Cartesian targets (name,x,y,z[,roll,pitch,yaw]; mm, degrees) in "
                                                "the frame chosen above, or a joints file (pose,q1..qn; degrees / "
                                                "mm) taught with the nominal model")
        self.clear_button = forms.button("Clear", "clearPointsButton")
        self.go_button = forms.button("Go to point", "goToPointButton",
                                      tooltip="Move the robot to the selected point with the calibrated model "
                                              "and measure where the marker is with the cameras")
        self.nominal_check = QCheckBox("Go with the nominal model")
        self.nominal_check.setObjectName("goNominal")
        self.nominal_check.setToolTip("No compensation: go to point with the joints the robot's own nominal model "
                                      "computes, to compare with the corrected joints")
        self.write_button = forms.button("Write corrected program…", "writeProgramButton",
                                         tooltip="The corrected joints as a joints file the Measurement page, "
                                                 "sim-robot and the robot drivers read")
        layout = QVBoxLayout(self)
        layout.addWidget(note)
        # rows that wrap when the panel is narrow (a small screen)
        point = FlowLayout()
        for axis, box in (("x", self.x_spin), ("y", self.y_spin), ("z", self.z_spin)):
            point.add_group(QLabel(axis), box)
        point.add_group(QLabel("in"), self.frame_combo)
        layout.addLayout(point)
        buttons = FlowLayout()
        for b in (self.add_button, self.clear_button, self.load_button, self.go_button, self.write_button):
            buttons.addWidget(b)
        layout.addLayout(buttons)
        layout.addWidget(self.nominal_check)
        layout.addStretch(1)
        self.load_button.clicked.connect(lambda *_: self._choose_program())
        self.write_button.clicked.connect(lambda *_: self._choose_output())

    @property
    def frame(self) -> str:
        return FRAMES[self.frame_combo.currentIndex()]

    def options(self) -> PointOptions:
        """The point typed (mm), its frame and the model Go to point uses."""
        return PointOptions((self.x_spin.value(), self.y_spin.value(), self.z_spin.value()), self.frame,
                            self.nominal_check.isChecked())

    def show_options(self, options: PointOptions) -> None:
        for box, value in zip((self.x_spin, self.y_spin, self.z_spin), options.point):
            box.setValue(value)
        self.frame_combo.setCurrentIndex(FRAMES.index(options.frame))
        self.nominal_check.setChecked(options.nominal)

    def _choose_program(self) -> None:
        path, _ = QFileDialog.getOpenFileName(self, "Program: targets (name,x,y,z…) or joints (pose,q1…)",
                                              str(self._folder() or ""), "CSV files (*.csv);;All files (*)")
        if path:
            self.programChosen.emit(path)

    def _choose_output(self) -> None:
        folder = self._folder()
        default = folder / PROGRAM_NAME if folder is not None else ""
        path, _ = QFileDialog.getSaveFileName(self, "Corrected program", str(default or ""), "Joint files (*.csv)")
        if path:
            self.outputChosen.emit(path)

    def set_enabled(self, busy: bool, ready: bool, has_points: bool, can_move: bool) -> None:
        for b in (self.add_button, self.load_button):
            b.setEnabled(ready and not busy)
        self.clear_button.setEnabled(has_points and not busy)
        self.write_button.setEnabled(ready and has_points and not busy)
        self.go_button.setEnabled(ready and has_points and can_move and not busy)
