"""`robocal stereo-calibrate`: stereo calibration from checkerboard image pairs. Not built yet (issue 3)."""
from __future__ import annotations

from app.commands import not_built

HELP = "Stereo calibration from checkerboard image pairs (not built yet)"


def add_arguments(parser) -> None:
    parser.add_argument("rest", nargs="*", help="arguments of the step, once it is built")


run = not_built("stereo calibration", 3)
