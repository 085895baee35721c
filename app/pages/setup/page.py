"""Step 1, Setup: project folder, robot model (DH table), robot connection, cameras.

The robot is the virtual lab's simulated robot or a controller on a serial port, tested here
(robot_panel.py); the cameras are the virtual lab's or two live cameras, video files or image
folders, previewed here (cameras_panel.py). The project's cell (the virtual lab or a real cell,
asked when the project is made) is shown with the project and changed with Change cell…; a
real-cell project offers only real hardware."""
from __future__ import annotations

from pathlib import Path

import numpy as np
from PySide6.QtCore import Qt
from PySide6.QtWidgets import (QComboBox, QFileDialog, QFrame, QGroupBox, QHBoxLayout, QLabel, QScrollArea,
                               QVBoxLayout, QWidget)

from app import project_actions
from app.html import esc
from app.pages import forms
from app.pages.base import WizardPage
from app.pages.setup.cameras_panel import CameraPanel
from app.pages.setup.cell_dialog import change_cell
from app.pages.setup.protocol_panel import ProtocolPanel
from app.pages.setup.robot_panel import RobotPanel
from app.pages.setup.urdf_dialog import ask_urdf_chain
from app.pages.steps import Step
from core import project as projects
from core.errors import RoboCalError
from core.files import read_json
from core.robot.model import RobotModel, preset_names, robot_path
from widgets.dh_table import DHTable

DEMO_PRESET = "educational_6r"
URDF_SUFFIXES = (".urdf", ".xacro", ".xml")       # read by the URDF importer, not as robot.json


def preset_title(name: str) -> str:
    """The display name written in a preset file (its file name if unreadable)."""
    try:
        return str(read_json(robot_path(name)).get("name", name))
    except RoboCalError:
        return name


def robot_summary(model: RobotModel) -> str:
    kinds = {j.type for j in model.joints}
    kind = next(iter(kinds)) if len(kinds) == 1 else "mixed"
    parts = [f"{model.dof} {kind} joints" if kind != "mixed" else f"{model.dof} joints"]
    for name, p in model.targets.items():
        parts.append(f"target “{name}” at ({', '.join(f'{v:g}' for v in np.round(p, 2))}) mm "
                     "in the tool frame")
    parallel = model.parallel_axis_joints()
    if parallel:
        pairs = ", ".join(f"J{i + 1}∥J{i + 2}" for i in parallel)
        parts.append(f"nearly parallel axes {pairs}: Hayati's β is identified there instead of d")
    return " · ".join(parts)


class SetupPage(WizardPage):
    step = Step.SETUP

    def __init__(self, state, tasks, **kwargs):
        super().__init__(state, tasks, **kwargs)
        self._syncing = False

        project_box = self._build_project_box()
        robot_box = self._build_robot_box()

        # -- connection and cameras ----------------------------------------------------
        self.robot_panel = RobotPanel(self)
        self.protocol_panel = ProtocolPanel(self, self.robot_panel)
        self.camera_panel = CameraPanel(self)
        self.camera_panel.preview.setMinimumHeight(220)

        content = QWidget()
        inner = QVBoxLayout(content)
        inner.setContentsMargins(0, 0, 6, 0)
        inner.addWidget(project_box)
        inner.addWidget(robot_box)
        inner.addWidget(self.robot_panel)
        inner.addWidget(self.protocol_panel)
        self.protocol_panel.setVisible(self.robot_panel.serial_radio.isChecked())
        self.robot_panel.serial_radio.toggled.connect(self.protocol_panel.setVisible)
        inner.addWidget(self.camera_panel, 1)
        scroll = self.scroll = QScrollArea()
        scroll.setWidgetResizable(True)
        scroll.setHorizontalScrollBarPolicy(Qt.ScrollBarPolicy.ScrollBarAsNeeded)   # a narrow window: scroll, never cut
        scroll.setFrameShape(QFrame.Shape.NoFrame)
        scroll.setWidget(content)

        layout = QVBoxLayout(self)
        layout.setContentsMargins(0, 0, 0, 0)
        layout.addWidget(scroll, 1)
        layout.addWidget(self.status)

        state.projectChanged.connect(self._refresh)
        state.cellChanged.connect(self._cell_changed)
        state.robotChanged.connect(self._refresh)
        state.hardware.connectionChanged.connect(self._refresh)
        self._refresh()

    def _build_project_box(self) -> QGroupBox:
        """The project folder, its details, New and Open."""
        self.project_folder = QLabel()
        self.project_folder.setTextInteractionFlags(Qt.TextInteractionFlag.TextSelectableByMouse)
        self.project_folder.setWordWrap(True)
        self.project_details = QLabel()
        self.project_details.setObjectName("hint")
        self.project_details.setWordWrap(True)
        self.new_button = forms.button("New project…", on_click=self.new_project)
        self.open_button = forms.button("Open project…", on_click=self.open_project)
        self.cell_button = forms.button("Change cell…", "changeCellButton", on_click=self.change_cell,
                                        tooltip="Measure on the virtual lab, or on a real cell: its robot "
                                                "connection and cameras")
        project_box = QGroupBox("Project")
        row = QHBoxLayout()
        text_col = QVBoxLayout()
        text_col.addWidget(self.project_folder)
        text_col.addWidget(self.project_details)
        row.addLayout(text_col, 1)
        row.addWidget(self.new_button)
        row.addWidget(self.open_button)
        row.addWidget(self.cell_button)
        project_box.setLayout(row)
        return project_box

    def _build_robot_box(self) -> QGroupBox:
        """The robot model: a preset or a robot.json, its name, DH table and summary."""
        self.preset_combo = QComboBox()
        self.preset_combo.setObjectName("presetCombo")
        self.preset_combo.addItem("— choose a preset —", None)
        for name in preset_names():
            self.preset_combo.addItem(preset_title(name), name)
        self.preset_combo.setMinimumContentsLength(18)
        self.preset_combo.currentIndexChanged.connect(self._preset_picked)
        self.load_button = forms.button("Load robot.json…", on_click=self.load_robot_file)
        self.urdf_button = forms.button("Load URDF…", "loadUrdfButton", on_click=self.load_urdf,
                                        tooltip="A robot model from a URDF file (expanded by xacro): choose the "
                                                "chain's base and tip links")
        self.robot_name = QLabel()
        self.robot_name.setObjectName("robotName")
        self.robot_summary = QLabel()
        self.robot_summary.setWordWrap(True)
        self.robot_summary.setObjectName("hint")
        self.dh_table = DHTable()
        robot_box = QGroupBox("Robot model (nominal DH parameters, eq. 1)")
        rl = QVBoxLayout(robot_box)
        pick = forms.row("Preset:", self.preset_combo, "or", self.load_button, self.urdf_button, stretch=False)
        pick.setStretchFactor(self.preset_combo, 1)
        rl.addLayout(pick)
        rl.addWidget(self.robot_name)
        rl.addWidget(self.dh_table)
        rl.addWidget(self.robot_summary)
        return robot_box

    # -- actions (also called by tests with explicit paths) ------------------------------
    def new_project(self, folder: str | Path | None = None):
        return project_actions.new_project(self, self.state, folder)

    def open_project(self, folder: str | Path | None = None):
        return project_actions.open_project(self, self.state, folder)

    def change_cell(self, cell=None) -> bool:
        """Change the project's cell: (mode, robot_connection, cameras), asked when not given."""
        return change_cell(self, self.state, cell)

    def _cell_changed(self, project) -> None:
        self.robot_panel.restore(project)
        self.camera_panel.restore(project)
        self._refresh()

    def choose_preset(self, name: str) -> RobotModel | None:
        try:
            return self.state.choose_preset(name)
        except RoboCalError as exc:
            self.show_error(exc.message)
            self._refresh()
            return None

    def load_robot_file(self, path: str | Path | None = None) -> RobotModel | None:
        if path is None:
            start = str(self.state.project.folder) if self.state.project else str(Path.home())
            path, _ = QFileDialog.getOpenFileName(self, "Load a robot model", start,
                                                  "Robot model (*.json *.urdf);;All files (*)")
            if not path:
                return None
        if Path(path).suffix.lower() in URDF_SUFFIXES:
            return self.load_urdf(path)
        try:
            return self.state.load_robot_file(path)
        except RoboCalError as exc:
            self.show_error(exc.message)
            self._refresh()
            return None

    def load_urdf(self, path: str | Path | None = None) -> RobotModel | None:
        """A robot model from a URDF (asked for when not given) through the same importer as
        `robocal robot-import`: its base and tip links chosen in a dialog, the model written to
        the project's robot.json."""
        if path is None:
            start = str(self.state.project.folder) if self.state.project else str(Path.home())
            path, _ = QFileDialog.getOpenFileName(self, "Load a robot model from a URDF", start,
                                                  "URDF (*.urdf *.xml);;All files (*)")
            if not path:
                return None
        try:
            imported = ask_urdf_chain(self, path)
            if imported is None:
                return None
            self.state.set_robot(imported.model, str(path))
        except RoboCalError as exc:
            self.show_error(exc.message)
            self._refresh()
            return None
        text = (f"✓ {imported.model.name}: {imported.model.dof} joints from '{imported.base_link}' to "
                f"'{imported.tip_link}' of {Path(path).name}." + "".join(f" Note: {n}." for n in imported.notes))
        if self.state.project is None:
            text += " To continue: create or open a project."
        self._set_status(text, ok=self.state.project is not None)
        return imported.model

    def _preset_picked(self, index: int) -> None:
        if self._syncing:
            return
        name = self.preset_combo.itemData(index)
        if name:
            self.choose_preset(name)

    # -- WizardPage ----------------------------------------------------------------------
    def is_complete(self) -> bool:
        return self.state.project is not None and self.state.robot is not None

    def on_enter(self) -> None:
        self._refresh()
        self.robot_panel.read_again()          # the robot may have moved on another page
        self.camera_panel.start_preview()

    def on_leave(self) -> None:
        self.camera_panel.stop_preview()
        self.protocol_panel.close_probe()

    def hideEvent(self, event) -> None:
        """Closed or another step shown: no preview worker or port probe is left running."""
        super().hideEvent(event)
        if not event.spontaneous():
            self.on_leave()

    def on_busy_changed(self) -> None:
        self.robot_panel.refresh()
        self.robot_panel.simulator_row.refresh()
        self.protocol_panel.refresh()
        self.camera_panel.refresh()

    def autopilot(self, done) -> None:
        try:
            if self.state.project is None:
                self.state.temporary_project()
            if self.state.robot is None:
                self.state.choose_preset(DEMO_PRESET)
        except RoboCalError as exc:
            done(False, exc.message)
            return
        done(self.is_complete(), "" if self.is_complete() else "no project or robot")

    # -- display -------------------------------------------------------------------------
    def _refresh(self, *_):
        state = self.state
        project = state.project
        if project is None:
            self.project_folder.setText("<b>No project yet.</b> A project is a folder that keeps "
                                        "the robot model and the output of every step.")
            self.project_details.setText("Create a new one, or open an existing project folder.")
        else:
            where = f"{project.folder}"
            if state.is_temporary():
                where += "  (temporary demo folder, deleted when RoboCal closes)"
            self.project_folder.setText(f"<b>{esc(project.name)}</b> — {esc(where)}")
            created = project.created.replace("T", " ").replace("+00:00", " UTC")
            self.project_details.setText(f"Cell: {esc(project.describe_cell())} · created {created or 'unknown'} · "
                                         f"format {projects.FORMAT}")
        self.cell_button.setEnabled(project is not None)

        model = state.robot
        self.dh_table.set_robot(model)
        self._syncing = True
        try:
            source = state.robot_source or ""
            preset = source[len("preset:"):] if source.startswith("preset:") else None
            index = self.preset_combo.findData(preset) if preset else -1
            if index < 0:
                self.preset_combo.setItemText(
                    0, f"From file: {Path(source).name}" if (model is not None and source) else "— choose a preset —")
                index = 0
            else:
                self.preset_combo.setItemText(0, "— choose a preset —")
            self.preset_combo.setCurrentIndex(index)
        finally:
            self._syncing = False
        if model is None:
            self.robot_name.setText("No robot model yet: choose a preset, or load a robot.json or a URDF file.")
            self.robot_summary.setText("")
        else:
            self.robot_name.setText(f"<b>{esc(model.name)}</b>")
            self.robot_summary.setText(robot_summary(model))

        hardware = project is not None and project.mode == projects.HARDWARE
        for virtual, real in ((self.robot_panel.virtual_radio, self.robot_panel.serial_radio),
                              (self.camera_panel.virtual_radio, self.camera_panel.sources_radio)):
            virtual.setEnabled(not hardware)
            if hardware and virtual.isChecked():
                real.setChecked(True)
        self.robot_panel.refresh()
        self.camera_panel.refresh()

        missing = []
        if project is None:
            missing.append("create or open a project")
        if model is None:
            missing.append("choose a robot model")
        if missing:
            self._set_status("To continue: " + " and ".join(missing) + ".", ok=False)
        else:
            self._set_status("✓ Ready: the project and the robot model are set. Press Next.", ok=True)
        self.notify_complete()
