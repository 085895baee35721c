"""The Setup step's model without Qt: what the page says of the project and the robot model, the
preset list's first line for a model from a file, and the robot box bound both ways."""
from __future__ import annotations

from core.project import HARDWARE, create_project
from core.robot.file import read_robot
from core.robot.model import robot_path
from app.pages.setup.model import NO_PRESET, RobotSource, SetupModel, describe, robot_source


def test_what_is_missing_is_said_and_a_ready_project_says_press_next(tmp_path):
    nothing = describe(None, False, None)
    assert not nothing.ok and not nothing.has_project and not nothing.hardware_only
    assert nothing.status == "To continue: create or open a project and choose a robot model."
    robot = read_robot(robot_path("educational_6r"))
    project = create_project(tmp_path / "lab <one>")
    view = describe(project, True, robot)
    assert view.ok and view.status.startswith("✓ Ready") and view.robot is robot
    assert "&lt;one&gt;" in view.project_title and "temporary demo folder" in view.project_title
    assert view.robot_name == f"<b>{robot.name}</b>" and f"{robot.dof} revolute joints" in view.robot_summary
    real = describe(create_project(tmp_path / "cell", mode=HARDWARE), False, None)
    assert real.hardware_only and real.status == "To continue: choose a robot model."


def test_the_robot_source_names_a_preset_or_the_file():
    robot = read_robot(robot_path("educational_6r"))
    assert robot_source(robot, "preset:educational_6r") == RobotSource("educational_6r", "From file: preset:educational_6r")
    assert robot_source(robot, "/x/y/arm.json") == RobotSource(None, "From file: arm.json")
    assert robot_source(None, "") == RobotSource(None, NO_PRESET)
    model = SetupModel()
    heard = []
    model.on("options", heard.append)
    model.on("result", lambda view: heard.append(view.status))
    model.update(None, False, robot, "/x/y/arm.json")
    model.update(None, False, robot, "/x/y/arm.json")           # the same source: only the view again
    assert heard == [RobotSource(None, "From file: arm.json"), "To continue: create or open a project.",
                     "To continue: create or open a project."]


def test_robot_box_shows_the_source_without_loading_it(qtbot):
    from app.pages.setup.robot_box import RobotBox
    box = RobotBox()
    qtbot.addWidget(box)
    picked = []
    box.presetChosen.connect(picked.append)
    box.show_options(RobotSource("educational_6r"))
    assert box.options().preset == "educational_6r" and picked == []
    box.show_options(RobotSource(None, "From file: arm.json"))
    assert box.options() == RobotSource(None, "From file: arm.json") and box.preset_combo.currentIndex() == 0
    box.preset_combo.setCurrentIndex(box.preset_combo.findData("educational_6r"))     # the technician picks it
    assert picked == ["educational_6r"]
