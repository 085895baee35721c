"""`robocal measure`: batch of pose images to a measurements file. Not built yet (issue 4)."""
from __future__ import annotations

from app.commands import not_built

HELP = "Batch of pose images to a measurements file (not built yet)"


def add_arguments(parser) -> None:
    parser.add_argument("rest", nargs="*", help="arguments of the step, once it is built")


run = not_built("measurement", 4)
