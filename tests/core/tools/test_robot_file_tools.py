"""Robot files with several tools: round trip, the one-tool default of older files, bad sections."""
from __future__ import annotations

import json

import pytest

from core.errors import RoboCalError
from core.robot.file import read_robot, robot_to_dict, write_robot
from core.robot.model import DEFAULT_TOOL, robot_path
from tests.core.tools.two_tools import two_tool_robot


def test_two_tools_round_trip(tmp_path):
    write_robot(two_tool_robot(), tmp_path / "r.json")
    back = read_robot(tmp_path / "r.json")
    assert back.tool_map() == {"gripper": ["marker"], "long_gripper": ["long_marker"]}
    assert back.targets["long_marker"].tolist() == [0.0, 15.0, 110.0]
    assert back.tool_of("long_marker") == "long_gripper" and back.tool_targets("gripper") == ["marker"]
    assert json.loads((tmp_path / "r.json").read_text())["tools"] == {"gripper": ["marker"],
                                                                     "long_gripper": ["long_marker"]}


def test_a_file_without_tools_has_one_tool_with_every_target(tmp_path):
    robot = read_robot(robot_path("educational_6r"))
    assert robot.tool_map() == {DEFAULT_TOOL: ["marker"]} and robot.tool_of("marker") == DEFAULT_TOOL
    assert "tools" not in robot_to_dict(robot)
    with pytest.raises(RoboCalError, match="no tool 'long_gripper'"):
        robot.tool_targets("long_gripper")


@pytest.mark.parametrize("tools, message", [
    ({"gripper": ["marker"], "long_gripper": ["lng"]}, "target 'lng' is not in"),
    ({"gripper": ["marker", "long_marker"], "long_gripper": ["long_marker"]}, "on both 'gripper' and"),
    ({"gripper": ["marker"]}, "target 'long_marker' is on no tool"),
    ({"gripper": []}, "non-empty list"),
    ([["marker"]], "expected an object"),
])
def test_bad_tools_name_the_file_and_field(tmp_path, tools, message):
    data = robot_to_dict(two_tool_robot())
    data["tools"] = tools
    (tmp_path / "r.json").write_text(json.dumps(data))
    with pytest.raises(RoboCalError, match=message) as err:
        read_robot(tmp_path / "r.json")
    assert err.value.field.startswith("tools") and "r.json" in str(err.value)
