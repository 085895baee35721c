"""The Pose sequence step's model without Qt: the project's poses.csv counts as the selection
until one is made, an unusable one is refused, and the controls bound both ways."""
from __future__ import annotations

import inspect

import numpy as np
import pytest

from app.jobs.poses import run_pose_selection
from app.pages.poses.model import PoseOptions, PosesModel
from core.errors import RoboCalError
from core.poses.file import write_poses
from core.poses.selection import select_poses
from core.project import Output, create_project
from core.robot.file import read_robot
from core.robot.model import robot_path


@pytest.fixture
def robot():
    return read_robot(robot_path("educational_6r"))


def test_the_projects_poses_count_until_a_selection_is_made(tmp_path, robot):
    project = create_project(tmp_path / "p")
    model = PosesModel()
    model.load_existing(project, robot)
    assert model.loaded is None and not model.complete                       # no poses.csv yet
    write_poses(project.path(Output.POSES), np.zeros((3, robot.dof)))
    model.load_existing(project, robot)
    assert len(model.loaded) == 3 and model.complete and model.result is None
    heard = []
    model.on("result", heard.append)
    selection = select_poses(robot, 12, candidates=300, seed=1, random_trials=1)
    model.selected(selection)
    assert heard == [selection] and model.loaded is None and model.complete
    model.load_existing(project, robot)
    assert model.loaded is None                                               # the selection wins
    model.selected(None)
    project.path(Output.POSES).write_text("pose,q1\n1,abc\n", encoding="utf-8")
    with pytest.raises(RoboCalError):
        model.load_existing(project, robot)
    assert model.loaded is None and not model.complete


def test_options_are_run_pose_selections_keywords(qtbot):
    from app.pages.poses.controls import SelectionControls
    assert set(PoseOptions().keywords()) <= set(inspect.signature(run_pose_selection).parameters)
    controls = SelectionControls()
    qtbot.addWidget(controls)
    assert controls.options() == PoseOptions()
    chosen = PoseOptions(count=12, index="O3", candidates=2500, margin=7.5, seed=42)
    controls.show_options(chosen)
    assert controls.options() == chosen and controls.index() == "O3"
    controls.set_demo()                                                       # the demo keeps margin and seed
    assert controls.options() == PoseOptions(margin=7.5, seed=42)
