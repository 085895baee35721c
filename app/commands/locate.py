"""`robocal locate`: 3D marker reference point from one stereo pair. Not built yet (issue 4)."""
from __future__ import annotations

from app.commands import not_built

HELP = "3D marker reference point from one stereo pair (not built yet)"


def add_arguments(parser) -> None:
    parser.add_argument("rest", nargs="*", help="arguments of the step, once it is built")


run = not_built("marker", 4)
