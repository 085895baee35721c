"""`robocal locate`: the 3D marker reference point from one stereo pair.

Prints `x y z` (mm, left camera frame). `--json` adds the image points in both images (raw
and rectified), the disparities (SSD and from the two reference points), the criteria minimum,
the reliability figure, the standard deviations and the triangulated marker size.

`--marker` is a training image of the marker (png, jpg, ...), a marker description (.json) or
a trained marker (.npz). For an image, a marker description with the same name beside it
(M.png + M.json) gives the outline and the physical size; otherwise the outline is found
automatically and the size is `--marker-size` (default: the shipped marker's 40 mm; the 3D
point does not depend on it, and without a known size the size check is skipped).
"""
from __future__ import annotations

from app.commands import CommandResult
from app.commands import options

HELP = "3D marker reference point (mm, left camera frame) from one stereo pair"


INPUTS = ("stereo", "marker", "left", "right")      # checked against OUTPUTS before the run (app/commands/paths.py)
OUTPUTS = ()


def add_arguments(parser) -> None:
    add_locator_arguments(parser)
    parser.add_argument("--left", required=True, metavar="L", help="left camera image")
    parser.add_argument("--right", required=True, metavar="R", help="right camera image")


def add_locator_arguments(parser) -> None:
    """--stereo, --marker and --marker-size: what `setup_locator` reads (locate, measure)."""
    parser.add_argument("--stereo", required=True, metavar="S",
                        help="stereo calibration: stereo.yaml, another tool's file (OpenCV, Kalibr, MATLAB JSON/MAT) "
                             "or a folder holding one (docs/file-formats.md)")
    parser.add_argument("--marker", required=True, metavar="M",
                        help="marker training image (png/jpg), marker description (.json) or trained marker (.npz)")
    parser.add_argument("--marker-size", type=options.size_mm, metavar="MM",
                        help="side of the marker's outer black square in mm (default: from the marker "
                             "description beside the image, else 40)")


def setup_locator(args):
    """(MarkerLocator, size known) from --stereo, --marker and --marker-size."""
    from core.errors import UsageError
    from core.marker import load_marker
    from core.marker.location import LocatorOptions, MarkerLocator
    from core.stereo.rectification import load_rectification

    if args.marker_size is not None and not args.marker_size > 0:
        raise UsageError("--marker-size must be positive (mm)")
    rect = load_rectification(args.stereo)
    trained, known = load_marker(args.marker, args.marker_size)
    options = LocatorOptions(max_size_error=0.2 if known else None)
    return MarkerLocator(trained, rect, options), known


def run(args) -> CommandResult:
    from core.errors import RoboCalError
    from core.images import read_camera_image

    locator, known = setup_locator(args)
    images = [read_camera_image(path, side, locator.rect.image_size)
              for side, path in (("left", args.left), ("right", args.right))]
    loc = locator.locate(images[0], images[1])
    if not loc.ok:
        raise RoboCalError(f"marker not located: {loc.reason}", source=args.left if loc.stage in ("left", "ssd")
                           else None,
                           hint="Check that both images show the whole marker and belong to this stereo calibration.")
    x, y, z = (float(v) for v in loc.point)
    data = loc.to_dict()
    data.update(stereo=str(args.stereo), marker=str(args.marker), left_image=str(args.left),
                right_image=str(args.right), marker_size_mm=locator.trained.outer_size, marker_size_known=known)
    return CommandResult(text=f"{x:.3f} {y:.3f} {z:.3f}", data=data)
