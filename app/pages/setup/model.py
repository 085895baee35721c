"""The Setup step's model, without Qt: the robot model chosen (a preset or a file) and what the
page shows of the project and the robot (`SetupView`, the step's result: the project and the
robot themselves are the wizard state's). `describe` turns the state into that view."""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from app.html import esc
from app.pages.step_model import StepModel
from core import project as projects
from core.errors import RoboCalError
from core.files import read_json
from core.robot.model import RobotModel, robot_path

NO_PRESET = "— choose a preset —"


def preset_title(name: str) -> str:
    """The display name written in a preset file (its file name if unreadable)."""
    try:
        return str(read_json(robot_path(name)).get("name", name))
    except RoboCalError:
        return name


def robot_summary(model: RobotModel) -> str:
    """Joints, targets (mm, tool frame) and nearly parallel axes of a robot model, in one line."""
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


@dataclass(frozen=True)
class RobotSource:
    """Where the robot model comes from: a preset's name, or else a file (`file_label`: its name
    as the first line of the preset list shows it)."""

    preset: str | None = None
    file_label: str = NO_PRESET          # the first line of the preset list


@dataclass(frozen=True)
class SetupView:
    """What the Setup page shows (rich text escaped)."""

    project_title: str
    project_details: str
    has_project: bool
    robot: RobotModel | None
    robot_name: str
    robot_summary: str
    hardware_only: bool                  # a real-cell project: no virtual robot or cameras
    status: str
    ok: bool


def robot_source(robot: RobotModel | None, source: str) -> RobotSource:
    """The preset of `source` ("preset:NAME"), or the file it names."""
    preset = source[len("preset:"):] if source.startswith("preset:") else None
    return RobotSource(preset, f"From file: {Path(source).name}" if (robot is not None and source) else NO_PRESET)


def describe(project, temporary: bool, robot: RobotModel | None) -> SetupView:
    """The texts of the project and the robot, and what is missing to go on."""
    if project is None:
        title = ("<b>No project yet.</b> A project is a folder that keeps "
                 "the robot model and the output of every step.")
        details = "Create a new one, or open an existing project folder."
    else:
        where = f"{project.folder}"
        if temporary:
            where += "  (temporary demo folder, deleted when RoboCal closes)"
        title = f"<b>{esc(project.name)}</b> — {esc(where)}"
        created = project.created.replace("T", " ").replace("+00:00", " UTC")
        details = (f"Cell: {esc(project.describe_cell())} · created {created or 'unknown'} · "
                   f"format {projects.FORMAT}")
    if robot is None:
        name, summary = "No robot model yet: choose a preset, or load a robot.json or a URDF file.", ""
    else:
        name, summary = f"<b>{esc(robot.name)}</b>", robot_summary(robot)
    missing = (["create or open a project"] if project is None else []) + \
              (["choose a robot model"] if robot is None else [])
    status = ("To continue: " + " and ".join(missing) + "." if missing else
              "✓ Ready: the project and the robot model are set. Press Next.")
    return SetupView(title, details, project is not None, robot, name, summary,
                     project is not None and project.mode == projects.HARDWARE, status, not missing)


class SetupModel(StepModel[RobotSource, SetupView]):
    """The robot model's source (options) and the view of the project and robot (result)."""

    def __init__(self):
        super().__init__(RobotSource())

    def update(self, project, temporary: bool, robot: RobotModel | None, source: str) -> SetupView:
        """Describe the state again: listeners of "options" hear a new source, of "result" the view."""
        self.set_options(robot_source(robot, source))
        self.set_result(describe(project, temporary, robot))
        return self.result
