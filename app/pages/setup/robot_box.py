"""The Setup page's robot model box: a preset or a robot.json or URDF file, the model's name, its
DH table and a summary. Signal `presetChosen(name)` when the technician picks a preset (the page
loads it; the box only redraws from the model)."""
from __future__ import annotations

from PySide6.QtCore import Signal
from PySide6.QtWidgets import QComboBox, QGroupBox, QLabel, QVBoxLayout

from app.pages import forms
from app.pages.setup.model import NO_PRESET, RobotSource, SetupView, preset_title
from core.robot.model import preset_names
from widgets.dh_table import DHTable


class RobotBox(QGroupBox):
    presetChosen = Signal(str)

    def __init__(self, parent=None):
        super().__init__("Robot model (nominal DH parameters, eq. 1)", parent)
        self._syncing = False
        self.preset_combo = QComboBox()
        self.preset_combo.setObjectName("presetCombo")
        self.preset_combo.addItem(NO_PRESET, None)
        for name in preset_names():
            self.preset_combo.addItem(preset_title(name), name)
        self.preset_combo.setMinimumContentsLength(18)
        self.preset_combo.currentIndexChanged.connect(self._picked)
        self.load_button = forms.button("Load robot.json…")
        self.urdf_button = forms.button("Load URDF…", "loadUrdfButton",
                                        tooltip="A robot model from a URDF file (expanded by xacro): choose the "
                                                "chain's base and tip links")
        self.robot_name = QLabel()
        self.robot_name.setObjectName("robotName")
        self.robot_summary = QLabel()
        self.robot_summary.setWordWrap(True)
        self.robot_summary.setObjectName("hint")
        self.dh_table = DHTable()
        layout = QVBoxLayout(self)
        pick = forms.row("Preset:", self.preset_combo, "or", self.load_button, self.urdf_button, stretch=False)
        pick.setStretchFactor(self.preset_combo, 1)
        layout.addLayout(pick)
        layout.addWidget(self.robot_name)
        layout.addWidget(self.dh_table)
        layout.addWidget(self.robot_summary)

    def options(self) -> RobotSource:
        """The preset picked (None: the first line, a file or nothing)."""
        return RobotSource(self.preset_combo.currentData(), self.preset_combo.itemText(0))

    def show_options(self, source: RobotSource) -> None:
        """Show `source` in the preset list without loading it again."""
        self._syncing = True
        try:
            index = self.preset_combo.findData(source.preset) if source.preset else -1
            self.preset_combo.setItemText(0, source.file_label if index < 0 else NO_PRESET)
            self.preset_combo.setCurrentIndex(max(index, 0))
        finally:
            self._syncing = False

    def show_view(self, view: SetupView, source: RobotSource) -> None:
        self.dh_table.set_robot(view.robot)
        self.show_options(source)
        self.robot_name.setText(view.robot_name)
        self.robot_summary.setText(view.robot_summary)

    def _picked(self, index: int) -> None:
        name = self.preset_combo.itemData(index)
        if name and not self._syncing:
            self.presetChosen.emit(name)
