"""The project folder of one wizard window: create, open and save it (core.project), and the
temporary demo projects, deleted when the window closes."""
from __future__ import annotations

import shutil
import tempfile
from pathlib import Path

from core import project as projects
from core.errors import RoboCalError
from core.robot.model import RobotModel


class ProjectFiles:
    """`project`: the current project (None: none open); the robot is saved beside it as
    robot.json with its source ("preset:ur5" or a file path)."""

    def __init__(self):
        self.project: projects.Project | None = None
        self._temp_dirs: list[Path] = []

    def create(self, folder: str | Path, name: str | None = None, mode: str = projects.VIRTUAL_LAB, *,
               robot_connection: projects.RobotConnection | None = None,
               cameras: projects.CameraSources | None = None) -> projects.Project:
        """A new project folder (not yet the current project)."""
        return projects.create_project(folder, name=name, mode=mode, robot_connection=robot_connection,
                                       cameras=cameras)

    def create_temporary(self, name: str) -> projects.Project:
        """A new project in a temporary folder, deleted by `close()` (demo, autopilot)."""
        folder = Path(tempfile.mkdtemp(prefix="robocal-demo-"))
        self._temp_dirs.append(folder)
        return self.create(folder / "project", name=name)

    def is_temporary(self) -> bool:
        return self.project is not None and any(d in self.project.folder.parents for d in self._temp_dirs)

    def save(self, robot: RobotModel | None, source: str | None) -> None:
        """Write project.json, and robot.json when a robot is chosen."""
        if self.project is None:
            raise RoboCalError("no project to save", hint="Create or open a project first.")
        projects.save_project(self.project)
        self.save_robot(robot, source)

    def save_robot(self, robot: RobotModel | None, source: str | None) -> None:
        """Write the robot into the current project (nothing without a project or a robot)."""
        if self.project is not None and robot is not None:
            projects.save_robot(self.project, robot, source)

    def close(self) -> None:
        """Delete the temporary projects. Safe to call twice."""
        for folder in self._temp_dirs:
            shutil.rmtree(folder, ignore_errors=True)
        self._temp_dirs.clear()
