"""What the wizard's pages share: the project, the robot model, the robot connection, the
virtual lab, and the results the steps hand to each other.

Every page gets the same `WizardState` (``self.state``) and listens to its signals rather
than to other pages. The project folder stays the durable truth: a step that produces a
file writes it with ``state.project.path("stereo")`` etc.; `outputs` holds the in-memory
result objects (e.g. the stereo calibration result) for the pages that follow.
"""
from __future__ import annotations

import shutil
import tempfile
from pathlib import Path
from typing import Any

from PySide6.QtCore import QObject, Signal

from core import project as projects
from app.lab import build_lab
from core.errors import RoboCalError
from core.robot.model import RobotModel, robot_path
from core.robot.driver import RobotDriver
from core.robot.simulated import SimulatedRobot
from core.robot.file import read_robot



class WizardState(QObject):
    """Shared state of one wizard window.

    Signals: `projectChanged(Project | None)`, `robotChanged(RobotModel | None)`,
    `connectionChanged(RobotDriver | None)`, `labChanged(VirtualLab | None)`,
    `outputChanged(str)` (name of the output set with `set_output`).
    """

    projectChanged = Signal(object)
    robotChanged = Signal(object)
    connectionChanged = Signal(object)
    labChanged = Signal(object)
    outputChanged = Signal(str)

    def __init__(self, parent: QObject | None = None, *, seed: int = 0, noise: float = 0.5):
        super().__init__(parent)
        self.project: projects.Project | None = None
        self.robot: RobotModel | None = None
        self.robot_source: str | None = None     # "preset:ur5" or a file path
        self.robot_connection: RobotDriver | None = None
        self.seed = seed                          # virtual lab: same seed, same lab
        self.noise = noise                        # virtual lab: sensor noise (grey levels)
        self.outputs: dict[str, Any] = {}
        self._lab = None
        self._temp_dirs: list[Path] = []

    # -- project -------------------------------------------------------------------------
    @property
    def mode(self) -> str:
        return self.project.mode if self.project is not None else projects.VIRTUAL_LAB

    @property
    def virtual(self) -> bool:
        return self.mode == projects.VIRTUAL_LAB

    def set_project(self, project: projects.Project | None, *, load_robot: bool = True) -> None:
        """Make `project` current. Its robot (if any) becomes the robot; if it has none and a
        robot is already chosen, that robot is written into the project."""
        robot = projects.load_robot(project) if (project is not None and load_robot) else None
        self.project = project
        self.outputs.clear()
        self.projectChanged.emit(project)
        if robot is not None:
            self.set_robot(robot, project.robot_source or str(project.path("robot")), persist=False)
        elif project is not None and self.robot is not None:
            projects.save_robot(project, self.robot, self.robot_source)
        self._update_connection()

    def new_project(self, folder: str | Path, name: str | None = None,
                    mode: str = projects.VIRTUAL_LAB) -> projects.Project:
        project = projects.create_project(folder, name=name, mode=mode)
        self.set_project(project)
        return project

    def open_project(self, folder: str | Path) -> projects.Project:
        project = projects.open_project(folder)
        self.set_project(project)
        return project

    def save_project(self) -> None:
        if self.project is None:
            raise RoboCalError("no project to save", hint="Create or open a project first.")
        projects.save_project(self.project)
        if self.robot is not None:
            projects.save_robot(self.project, self.robot, self.robot_source)

    def temporary_project(self, name: str = "RoboCal demo") -> projects.Project:
        """A new project in a temporary folder, deleted by `close()` (demo, autopilot)."""
        folder = Path(tempfile.mkdtemp(prefix="robocal-demo-"))
        self._temp_dirs.append(folder)
        return self.new_project(folder / "project", name=name)

    def is_temporary(self) -> bool:
        return self.project is not None and any(
            d in self.project.folder.parents for d in self._temp_dirs)

    # -- robot ---------------------------------------------------------------------------
    def set_robot(self, model: RobotModel | None, source: str | None = None, *,
                  persist: bool = True) -> None:
        """Make `model` the nominal robot; with a project open, also write it to robot.json."""
        if model is not None and persist and self.project is not None:
            projects.save_robot(self.project, model, source)
        self.robot = model
        self.robot_source = source
        self._set_lab(None)
        self.robotChanged.emit(model)
        self._update_connection()

    def choose_preset(self, name: str) -> RobotModel:
        model = read_robot(robot_path(name))
        self.set_robot(model, f"preset:{name}")
        return model

    def load_robot_file(self, path: str | Path) -> RobotModel:
        model = read_robot(path)
        self.set_robot(model, str(path))
        return model

    # -- robot connection ----------------------------------------------------------------
    def _update_connection(self) -> None:
        """Virtual lab mode: a simulated robot over the lab's true geometry once the lab
        exists (over the nominal model before). Hardware drivers arrive with their issue."""
        old = self.robot_connection
        new: RobotDriver | None = None
        if self.robot is not None and self.virtual:
            truth = getattr(self._lab, "true_robot", None) if self._lab is not None else None
            new = SimulatedRobot(truth if isinstance(truth, RobotModel) else self.robot)
            new.connect()
        if old is not None:
            if old.stopped and new is not None:
                new.stop()                  # a Stop latches until the user resumes, whatever replaced the driver
            old.stop()
            old.disconnect()
        self.robot_connection = new
        self.connectionChanged.emit(new)

    def stop_robot(self) -> bool:
        """Stop the robot now (the Stop key). Returns True if there was a robot to stop."""
        if self.robot_connection is None:
            return False
        self.robot_connection.stop()
        return True

    # -- virtual lab ---------------------------------------------------------------------
    @property
    def lab(self):
        """The virtual lab for the current robot, created on first use
        (``VirtualLab.create(robot=..., seed=..., noise=...)``)."""
        if self._lab is None:
            self._set_lab(build_lab(self.robot, self.seed, self.noise))
            self._update_connection()
        return self._lab

    @property
    def has_lab(self) -> bool:
        return self._lab is not None

    def adopt_lab(self, lab) -> None:
        """Take a lab a page built on a worker thread (VirtualLab.create takes ~2 s, too long
        for the GUI thread), so that later pages reuse it. Ignored if the state already has
        one, or if it was built for another robot, seed or noise."""
        if self._lab is not None or lab is None or self.robot is None:
            return
        if (getattr(lab, "seed", None), getattr(lab, "noise", None)) != (self.seed, float(self.noise)):
            return
        nominal = getattr(lab, "nominal_robot", None)
        if nominal is None or nominal.name != self.robot.name or nominal.dof != self.robot.dof:
            return
        self._set_lab(lab)
        self._update_connection()

    def _set_lab(self, lab) -> None:
        if lab is self._lab:
            return
        self._lab = lab
        self.labChanged.emit(lab)

    # -- outputs of the steps ------------------------------------------------------------
    def set_output(self, name: str, value: Any) -> None:
        self.outputs[name] = value
        self.outputChanged.emit(name)

    # -- end -----------------------------------------------------------------------------
    def close(self) -> None:
        """Stop and disconnect the robot, delete temporary projects. Safe to call twice."""
        if self.robot_connection is not None:
            self.robot_connection.stop()
            self.robot_connection.disconnect()
        for folder in self._temp_dirs:
            shutil.rmtree(folder, ignore_errors=True)
        self._temp_dirs.clear()
