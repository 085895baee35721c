"""The connected cell on the command line (`robocal check`, `robocal identify-tool`): the
arguments that name it (`--port`, `--profile`, `--cameras`, `--cell-clear`) and the confirmation
of the robot's motion.

A real robot's first motion is confirmed by the person who started the run: on an interactive
terminal the command asks once, after it chose the poses and before it connects to the robot
("The robot on PORT will move to N poses. Is the cell clear …? [y/N]"); anything but yes
moves nothing (exit 1). An unattended run (cron, a systemd timer: no terminal to answer) says
with `--cell-clear` that the cell is clear and guarded; without it the run is refused before any
work, in one line naming the flag (exit 2), and the robot never moves.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

from core.errors import RoboCalError, UsageError

CELL_CLEAR = "--cell-clear"


def camera_pair(text: str) -> tuple[str, str]:
    """'LEFT,RIGHT' -> the two cameras as typed: device indices (0), device paths, video files or
    image folders (app.hardware.camera_spec reads each)."""
    parts = [p.strip() for p in str(text).split(",")]
    if len(parts) != 2 or not all(parts):
        raise argparse.ArgumentTypeError(f"expected two cameras LEFT,RIGHT (device indices 0,1, video files or "
                                         f"image folders, left first), got {text!r}")
    return parts[0], parts[1]


camera_pair.__name__ = "camera pair"


def protocol_profile(text: str) -> str:
    """The controller's protocol profile as typed, checked before anything connects: a built-in
    name (resources/robots/profiles) or a profile file that reads as one."""
    from core.robot.profile import builtin_names, read_profile

    name = str(text).strip()
    if name in builtin_names():
        return name
    builtins = ", ".join(builtin_names())
    if not Path(name).is_file():
        raise argparse.ArgumentTypeError(f"no protocol profile {text!r}: give a built-in one ({builtins}) or the path "
                                         "of a protocol profile file (JSON)")
    try:
        read_profile(name)
    except RoboCalError as exc:
        raise argparse.ArgumentTypeError(f"the profile file cannot be used: {exc.message}") from None
    return name


protocol_profile.__name__ = "protocol profile"


def add_arguments(parser, *, port_help: str, title: str = "the connected cell") -> None:
    """The connected cell's arguments in their own group; `port_help` says what the command does
    with the robot on that port."""
    cell = parser.add_argument_group(title)
    cell.add_argument("--port", metavar="PORT", help=port_help)
    cell.add_argument("--profile", metavar="NAME", default="robocal_v1", type=protocol_profile,
                      help="the controller's protocol profile (default robocal_v1; grbl_joint_arm, mecademic_meca500, "
                           "or a profile file)")
    cell.add_argument("--cameras", type=camera_pair, metavar="LEFT,RIGHT",
                      help="the two cameras: device indices (0,1), device paths, video files or image folders")
    cell.add_argument(CELL_CLEAR, action="store_true",
                      help="the cell is clear and guarded: move the robot without asking first (needed where no "
                           "one can answer: cron, a systemd timer)")


def given(args) -> bool:
    """Whether the command was asked to measure on the connected cell."""
    return bool(args.port or args.cameras)


def interactive(stdin=None) -> bool:
    """Someone can answer on this terminal."""
    stdin = sys.stdin if stdin is None else stdin
    try:
        return bool(stdin is not None and stdin.isatty())
    except (AttributeError, ValueError, OSError):
        return False


def require_confirmable(args, stdin=None) -> None:
    """UsageError (exit 2) before any work when the robot would move with no one to confirm it:
    no terminal and no --cell-clear."""
    if not args.cell_clear and not interactive(stdin):
        raise UsageError(f"no terminal to confirm the robot's motion: add {CELL_CLEAR} once the cell is clear "
                         "and guarded (unattended runs: cron, systemd timers)")


def confirm_motion(args, what: str, *, stdin=None, stream=None) -> None:
    """Ask once before the robot first moves (`what`: where it will move, e.g. "8 check poses"),
    unless --cell-clear said the cell is clear. RoboCalError (nothing moved) unless the answer is yes."""
    if args.cell_clear:
        return
    require_confirmable(args, stdin)
    stdin = sys.stdin if stdin is None else stdin
    stream = sys.stderr if stream is None else stream
    stream.write(f"The robot on {args.port} will move to {what}. Is the cell clear and the emergency stop within "
                 "reach? [y/N] ")
    stream.flush()
    answer = stdin.readline()
    if answer.strip().lower() not in ("y", "yes"):
        raise RoboCalError("motion not confirmed: the robot was not moved",
                           hint=f"Clear the cell and answer y, or give {CELL_CLEAR}.")
