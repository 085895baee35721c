"""The connected cell's arguments (`--cameras`, `--profile`, `--cell-clear`) as a command parses them,
and the confirmation of the robot's first motion: asked once on a terminal (a real pseudo-terminal
here), refused with no terminal and no --cell-clear, and nothing but yes accepted. The same through
`robocal check --port` on the controller simulator: tests/app/commands/test_check_port.py."""
from __future__ import annotations

import argparse
import io
import os

import pytest

from app.commands import connected_cell
from core.errors import RoboCalError, UsageError


def parsed(*argv: str) -> argparse.Namespace:
    parser = argparse.ArgumentParser(prog="robocal check", exit_on_error=False)
    connected_cell.add_arguments(parser, port_help="the robot to move")
    return parser.parse_args(list(argv))


def test_the_two_cameras_and_a_built_in_profile_are_read_as_typed():
    args = parsed("--port", "/dev/ttyUSB0", "--cameras", "0, /data/right", "--profile", "grbl_joint_arm")
    assert args.cameras == ("0", "/data/right") and args.profile == "grbl_joint_arm"
    assert connected_cell.given(args) and not args.cell_clear
    assert parsed().profile == "robocal_v1" and not connected_cell.given(parsed())


@pytest.mark.parametrize("cameras", ["0", "0,1,2", "0,", " ,1"])
def test_anything_but_two_cameras_is_refused(cameras):
    with pytest.raises(argparse.ArgumentError, match="expected two cameras LEFT,RIGHT"):
        parsed("--cameras", cameras)


def test_a_profile_that_is_no_built_in_and_no_readable_file_is_refused(tmp_path):
    with pytest.raises(argparse.ArgumentError, match="give a built-in one .*robocal_v1"):
        parsed("--profile", "kuka")
    bad = tmp_path / "arm.json"
    bad.write_text('{"format": "robocal.protocol-profile/1"}')
    with pytest.raises(argparse.ArgumentError, match="the profile file cannot be used: .*arm.json"):
        parsed("--profile", str(bad))


@pytest.fixture
def terminal():
    """(what the command reads, what the person types into): a real pseudo-terminal."""
    main_fd, sub_fd = os.openpty()
    typed = os.fdopen(main_fd, "w", buffering=1)
    stdin = os.fdopen(sub_fd, "r")
    yield stdin, typed
    stdin.close()
    typed.close()


@pytest.mark.parametrize("answer, moves", [("y", True), ("YES", True), ("n", False), ("", False), ("sure", False)])
def test_on_a_terminal_the_motion_is_asked_once_and_only_yes_moves(terminal, answer, moves):
    stdin, typed = terminal
    asked = io.StringIO()
    typed.write(answer + "\n")
    args = parsed("--port", "/dev/ttyUSB0")
    if moves:
        connected_cell.confirm_motion(args, "8 check poses", stdin=stdin, stream=asked)
    else:
        with pytest.raises(RoboCalError, match="motion not confirmed: the robot was not moved") as info:
            connected_cell.confirm_motion(args, "8 check poses", stdin=stdin, stream=asked)
        assert "--cell-clear" in info.value.hint
    assert asked.getvalue() == ("The robot on /dev/ttyUSB0 will move to 8 check poses. Is the cell clear and the "
                                "emergency stop within reach? [y/N] ")


def test_without_a_terminal_only_cell_clear_lets_the_robot_move():
    not_a_terminal = io.StringIO("y\n")
    with pytest.raises(UsageError, match="no terminal to confirm the robot's motion: add --cell-clear"):
        connected_cell.require_confirmable(parsed("--port", "p"), not_a_terminal)
    asked = io.StringIO()
    connected_cell.confirm_motion(parsed("--port", "p", "--cell-clear"), "3 poses", stdin=not_a_terminal,
                                  stream=asked)
    assert asked.getvalue() == "" and not_a_terminal.read() == "y\n"      # nothing asked, nothing read
