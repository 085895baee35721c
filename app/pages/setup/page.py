"""Step 1, Setup: project folder, robot model (DH table), robot connection, cameras.

The robot is the virtual lab's simulated robot or a controller on a serial port, tested here
(robot_panel.py); the cameras are the virtual lab's or two live cameras, video files or image
folders, previewed here (cameras_panel.py). The project's cell (the virtual lab or a real cell,
asked when the project is made) is shown with the project and changed with Change cell…; a
real-cell project offers only real hardware. What the page shows of the project and the robot
model comes from its model (model.py), drawn by the Project and Robot model boxes."""
from __future__ import annotations

from pathlib import Path

from PySide6.QtCore import Qt
from PySide6.QtWidgets import QFileDialog, QFrame, QScrollArea, QVBoxLayout, QWidget

from app import project_actions
from app.cell_dialog import change_cell
from app.pages.base import WizardPage
from app.pages.setup.cameras_panel import CameraPanel
from app.pages.setup.model import SetupModel, SetupView
from app.pages.setup.project_box import ProjectBox
from app.pages.setup.protocol_panel import ProtocolPanel
from app.pages.setup.robot_box import RobotBox
from app.pages.setup.robot_panel import RobotPanel
from app.pages.setup.urdf_dialog import ask_urdf_chain
from app.pages.steps import Step
from core.errors import RoboCalError
from core.robot.model import RobotModel

DEMO_PRESET = "educational_6r"
URDF_SUFFIXES = (".urdf", ".xacro", ".xml")       # read by the URDF importer, not as robot.json


class SetupPage(WizardPage):
    step = Step.SETUP

    def __init__(self, state, tasks, **kwargs):
        super().__init__(state, tasks, **kwargs)
        self.model = SetupModel()
        project_box = self.project_box = ProjectBox()
        robot_box = self.robot_box = RobotBox()
        # the boxes' widgets, as the tests and the autopilot reach them
        self.project_folder, self.project_details = project_box.project_folder, project_box.project_details
        self.new_button, self.open_button, self.cell_button = (project_box.new_button, project_box.open_button,
                                                               project_box.cell_button)
        self.preset_combo, self.dh_table = robot_box.preset_combo, robot_box.dh_table
        self.load_button, self.urdf_button = robot_box.load_button, robot_box.urdf_button
        self.robot_name, self.robot_summary = robot_box.robot_name, robot_box.robot_summary
        self.new_button.clicked.connect(lambda *_: self.new_project())
        self.open_button.clicked.connect(lambda *_: self.open_project())
        self.cell_button.clicked.connect(lambda *_: self.change_cell())
        self.load_button.clicked.connect(lambda *_: self.load_robot_file())
        self.urdf_button.clicked.connect(lambda *_: self.load_urdf())
        robot_box.presetChosen.connect(self.choose_preset)
        self.model.on("result", project_box.show_view)
        self.model.on("result", lambda view: robot_box.show_view(view, self.model.options))
        self.model.on("result", self._show_view)

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
    def _refresh(self, *_) -> None:
        state = self.state
        self.model.update(state.project, state.is_temporary(), state.robot, state.robot_source or "")
        self.notify_complete()

    def _show_view(self, view: SetupView) -> None:
        """A real-cell project offers only real hardware; the panels and the status line redrawn."""
        for virtual, real in ((self.robot_panel.virtual_radio, self.robot_panel.serial_radio),
                              (self.camera_panel.virtual_radio, self.camera_panel.sources_radio)):
            virtual.setEnabled(not view.hardware_only)
            if view.hardware_only and virtual.isChecked():
                real.setChecked(True)
        self.robot_panel.refresh()
        self.camera_panel.refresh()
        self._set_status(view.status, ok=view.ok)
