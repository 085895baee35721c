"""`robocal gui`: open the wizard. Not built yet (issue 2)."""
from __future__ import annotations

from app.commands import not_built

HELP = "Open the wizard (not built yet)"


def add_arguments(parser) -> None:
    parser.add_argument("rest", nargs="*", help="arguments of the step, once it is built")


run = not_built("wizard shell", 2)
