"""`robocal identify`: kinematic identification of the robot model. Not built yet (issue 5)."""
from __future__ import annotations

from app.commands import not_built

HELP = "Kinematic identification of the robot model (not built yet)"


def add_arguments(parser) -> None:
    parser.add_argument("rest", nargs="*", help="arguments of the step, once it is built")


run = not_built("identification", 5)
