"""`robocal select-poses`: pose sequence chosen by observability. Not built yet (issue 6)."""
from __future__ import annotations

from app.commands import not_built

HELP = "Pose sequence chosen by observability (not built yet)"


def add_arguments(parser) -> None:
    parser.add_argument("rest", nargs="*", help="arguments of the step, once it is built")


run = not_built("pose selection", 6)
