"""New / Open / Save project, shared by the File menu and the Setup page.

Each action asks for a folder when none is given (New project and Save the demo take a new
folder's name too: the folder is created), shows a RoboCalError as one message box
line, and returns the project (or None when cancelled or failed). New project also asks which
cell the project measures on (the virtual lab or a real cell, app/cell_dialog.py)
when it asks for the folder; given a folder and no cell, it makes a virtual-lab project."""
from __future__ import annotations

import shutil
from pathlib import Path

from PySide6.QtWidgets import QFileDialog, QWidget

from app.cell_dialog import ask_cell
from app.messages import show_error
from app.new_folder_dialog import ask_new_folder
from app.state import WizardState
from core.errors import RoboCalError
from core.project import Output, PROJECT_FILE, Project


def new_project(parent: QWidget | None, state: WizardState, folder: str | Path | None = None,
                cell: tuple[str, dict | None, dict | None] | None = None) -> Project | None:
    """`cell`: (mode, robot_connection, cameras) as CellDialog.cell() gives them."""
    if folder is None:
        folder = ask_new_folder(parent, "New project: choose an empty folder or type a new folder's name")
        if folder is None:
            return None
        if cell is None:
            cell = ask_cell(parent)
            if cell is None:
                return None
    try:
        if cell is None:
            return state.new_project(folder)
        mode, robot_connection, cameras = cell
        return state.new_project(folder, mode=mode, robot_connection=robot_connection, cameras=cameras)
    except RoboCalError as exc:
        show_error(parent, exc.message, "RoboCal: new project")
        return None


def open_project(parent: QWidget | None, state: WizardState, folder: str | Path | None = None) -> Project | None:
    if folder is None:
        folder = QFileDialog.getExistingDirectory(
            parent, "Open project: choose a project folder", str(Path.home()))
        if not folder:
            return None
    try:
        return state.open_project(folder)
    except RoboCalError as exc:
        show_error(parent, exc.message, "RoboCal: open project")
        return None


def save_project(parent: QWidget | None, state: WizardState) -> bool:
    try:
        state.save_project()
    except RoboCalError as exc:
        show_error(parent, exc.message, "RoboCal: save project")
        return False
    return True


def demo_has_results(state: WizardState) -> bool:
    """A temporary (demo) project holds work beyond its project and robot files."""
    project = state.project
    if project is None or not state.is_temporary():
        return False
    setup = {PROJECT_FILE, project.path(Output.ROBOT).name}
    return any(p.name not in setup for p in project.folder.iterdir())


def save_demo_as_project(parent: QWidget | None, state: WizardState, folder: str | Path | None = None
                         ) -> Project | None:
    """Copy the temporary demo project (its images, results, exports, report) into `folder`
    (asked for; a new or empty folder) and make the copy the open project."""
    if folder is None:
        folder = ask_new_folder(parent, "Save the demo as a project: choose an empty folder or type a new "
                                        "folder's name")
        if folder is None:
            return None
    folder = Path(folder)
    try:
        if folder.exists() and (not folder.is_dir() or any(folder.iterdir())):
            raise RoboCalError("the folder is not empty", source=folder,
                               hint="Choose a new or an empty folder for the demo's project.")
        state.save_project()
        shutil.copytree(state.project.folder, folder, dirs_exist_ok=True)
        return state.open_project(folder)
    except OSError as exc:
        show_error(parent, f"{folder}: cannot copy the demo there ({exc.strerror or exc}).", "RoboCal: save demo")
    except RoboCalError as exc:
        show_error(parent, exc.message, "RoboCal: save demo")
    return None
