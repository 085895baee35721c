"""`robocal simulate`: write a virtual-lab dataset. Not built yet (issue 2)."""
from __future__ import annotations

from app.commands import not_built

HELP = "Write a virtual-lab dataset (not built yet)"


def add_arguments(parser) -> None:
    parser.add_argument("rest", nargs="*", help="arguments of the step, once it is built")


run = not_built("virtual lab", 2)
