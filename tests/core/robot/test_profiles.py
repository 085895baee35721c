"""Protocol profiles: the built-in ones load and read their controllers' documented replies;
a broken profile is a clear error naming the field."""
from __future__ import annotations

import json

import pytest

from core.errors import RoboCalError
from core.resources import resource_path
from core.robot.profile import builtin_names, builtin_profile, read_profile


def test_builtin_profiles():
    assert builtin_names() == ["grbl_joint_arm", "mecademic_meca500", "robocal_v1"]
    meca = builtin_profile("mecademic_meca500")
    assert meca.format_move([1, -2, 3, 0, 45, 90]) == "MoveJoints(1.0000,-2.0000,3.0000,0.0000,45.0000,90.0000)"
    m = meca.position.reply.match("[2026][10.5,-20,30,0,45,-90.25]")
    assert meca.parse_values(m.group("values")) == [10.5, -20, 30, 0, 45, -90.25]
    assert meca.done_poll.reply.match("[2007][1,1,0,0,0,1,1]")
    assert not meca.done_poll.reply.match("[2007][1,1,0,0,0,0,0]") and meca.done_busy.match("[2007][1,1,0,0,0,0,0]")
    err = meca.error.match("[1016][Destination pose out of reach.]")
    assert err.group("code") == "1016" and any(i.match("[3000][Connected to Meca500.]") for i in meca.ignore)
    grbl = builtin_profile("grbl_joint_arm")
    status = "<Run|MPos:1.000,-2.500,3.000,0.000,0.000,90.000|FS:500,0>"
    assert grbl.parse_values(grbl.position.reply.match(status).group("values"))[1] == -2.5
    assert grbl.done_busy.match(status) and not grbl.done_poll.reply.match(status)
    assert grbl.done_poll.reply.match("<Idle|MPos:0.000,0.000,0.000,0.000,0.000,0.000|FS:0,0>")
    assert grbl.error.match("ALARM:1").group("code") == "ALARM:1"
    assert [cmd for _, cmd in grbl.speed_levels] == ["\x97", "\x96", "\x95"]


@pytest.mark.parametrize("change, field", [({"move": {"send": "MOVE"}}, "move.send"),
                                           ({"error": "^ERR ("}, "error"),
                                           ({"done": None}, "settle"),
                                           ({"format": "robocal.robot/1"}, "format")])
def test_broken_profiles_name_the_field(tmp_path, change, field):
    data = json.loads(resource_path("robots", "profiles", "robocal_v1.json").read_text(encoding="utf-8"))
    data.update(change)
    path = tmp_path / "p.json"
    path.write_text(json.dumps(data))
    with pytest.raises(RoboCalError) as info:
        read_profile(path)
    assert info.value.field == field and str(path) in info.value.message


def test_the_commands_a_profile_says_get_no_reply():
    grbl, robocal, meca = (builtin_profile(n) for n in ("grbl_joint_arm", "robocal_v1", "mecademic_meca500"))
    assert not grbl.expects_reply(("\x97",)) and not grbl.expects_reply(("\x95",))     # rapid overrides
    assert grbl.expects_reply(("?",)) and grbl.expects_reply(("!", "\x18")) and grbl.expects_reply(("$X",))
    assert robocal.expects_reply(("SPEED 25",)) and robocal.expects_reply(("STOP",))
    assert not meca.expects_reply(("SetJointVel(25)",)) and not meca.expects_reply(("SetJointVel(12.5)",))
    assert meca.expects_reply(("SetJointVel(25); x",)) and meca.expects_reply(("ResumeMotion",))
