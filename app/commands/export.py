"""`robocal export`: export a robot model as URDF or a DH table. Not built yet (issue 5)."""
from __future__ import annotations

from app.commands import not_built

HELP = "Export a robot model as URDF or a DH table (not built yet)"


def add_arguments(parser) -> None:
    parser.add_argument("rest", nargs="*", help="arguments of the step, once it is built")


run = not_built("export", 5)
