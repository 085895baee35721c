"""The protocol test: templates of a profile sent over a real pty to the controller simulator
(RoboCal v1 and GRBL), the raw replies and what the profile's patterns matched; a move typed
by hand is refused before anything is written; a connected driver lends its link."""
from __future__ import annotations

import time

import pytest

from core.errors import RoboCalError
from core.robot.controller_sim import ControllerSim
from core.robot.file import read_robot
from core.robot.model import robot_path
from core.robot.profile import builtin_profile
from core.robot.profile_probe import ProfileProbe, match_line, templates
from core.robot.serial_robot import SerialRobot


@pytest.fixture(scope="module")
def model():
    return read_robot(robot_path("educational_6r"))


def probe_on(model, protocol, profile_name):
    sim = ControllerSim(model, protocol=protocol, time_scale=0.05).start()
    probe = ProfileProbe.open(builtin_profile(profile_name), sim.port)
    return sim, probe


def names(reply):
    return [m.pattern for m in reply.matches]


def test_robocal_templates_replies_and_matches(model):
    sim, probe = probe_on(model, "robocal", "robocal_v1")
    try:
        t = templates(probe.profile)
        assert t["identify"] == ("HELLO",) and t["speed"] == ("SPEED 25",) and t["stop"] == ("STOP",)
        hello = probe.send(t["identify"])
        assert [r.text for r in hello.replies] == ["ROBOCAL 1 Educational_6R_arm_(Robix_RCS-6_style) 6"]
        m = hello.replies[0].matches
        assert names(hello.replies[0]) == ["hello"] and m[0].groups == {"name": "Educational_6R_arm_(Robix_RCS-6_style)", "dof": "6"}

        pos = probe.send(t["position"]).replies[0]
        assert names(pos) == ["position"] and pos.matches[0].values == (0.0,) * 6

        joints = pos.matches[0].values
        move = templates(probe.profile, joints)["move (to the joints read)"]
        assert move == ("MOVE 0.0000 0.0000 0.0000 0.0000 0.0000 0.0000",)
        ex = probe.send(move, allowed_move=move[0])
        assert [(r.text, names(r)) for r in ex.replies] == [("ACK", ["move ok"]), ("DONE", ["done"])]

        bad = probe.send("FROB 1").replies[0]
        assert names(bad) == ["error"] and bad.matches[0].groups["code"] == "SYNTAX"
        assert probe.send(t["speed"]).replies[0].text == "OK" and sim.speed == 25.0
    finally:
        probe.close()
        sim.close()


def test_grbl_status_query_matches_position_and_idle(model):
    sim, probe = probe_on(model, "grbl", "grbl_joint_arm")
    try:
        t = templates(probe.profile, [1, 2, 3, 4, 5, 6])
        assert t["speed"] == ("\x97",) and t["stop"] == ("!", "\x18") and t["resume"] == ("$X",)
        assert t["move (to the joints read)"] == ("G90 G0 X1.000 Y2.000 Z3.000 A4.000 B5.000 C6.000",)
        status = probe.send("?").replies[0]
        assert status.text.startswith("<Idle|MPos:0.000,0.000")
        assert names(status) == ["hello", "position", "done", "tolerated during a stop"]
        assert status.matches[1].values == (0.0,) * 6 and status.matches[0].groups["state"] == "Idle"
        unlocked = probe.send("$X").replies
        assert [(r.text, names(r)) for r in unlocked] == [("ok", ["move ok", "resume ok", "tolerated during a stop"])]
        typed = probe.send("M3")
        err = typed.replies[0]
        assert names(err) == ["error"] and err.matches[0].groups["code"] == "error:20" and typed.reply_expected
        assert sim.received[-2:] == ["$X", "M3"]                     # `?` went as a real-time byte, no line
        speed = probe.send(t["speed"])                                # the rapid override: GRBL never replies
        assert speed.replies == [] and not speed.reply_expected and sim.speed == 25.0
    finally:
        probe.close()
        sim.close()


def test_a_move_typed_by_hand_is_refused_before_anything_is_written(model):
    sim, probe = probe_on(model, "robocal", "robocal_v1")
    try:
        with pytest.raises(RoboCalError) as info:
            probe.send("MOVE 170 0 0 0 0 0")
        assert "typed by hand" in info.value.message
        with pytest.raises(RoboCalError):
            probe.send("move 0 0 0 0 0 0", allowed_move="MOVE 0.0000 0.0000 0.0000 0.0000 0.0000 0.0000")
        time.sleep(0.1)
        assert sim.received == [] and sim.moves == 0
    finally:
        probe.close()
        sim.close()


def test_a_line_no_pattern_knows_is_shown_unmatched():
    profile = builtin_profile("robocal_v1")
    assert match_line(profile, "HELLO THERE") == ()
    assert [m.pattern for m in match_line(profile, "STOPPED")] == ["stop"]


def test_a_connected_driver_lends_its_link(model):
    with ControllerSim(model, time_scale=0.05) as sim:
        driver = SerialRobot(model, sim.port, "robocal_v1", reply_timeout=5.0)
        driver.connect()
        try:
            with driver.borrow_link() as link:
                ex = ProfileProbe(driver.profile, link).send("POS?")
            assert names(ex.replies[0]) == ["position"]
            assert list(driver.current_joints()) == [0.0] * 6          # the driver goes on cleanly
        finally:
            driver.disconnect()
