"""`robocal stereo-import`: a stereo calibration made by another tool, as RoboCal's stereo.yaml.

SOURCE is one file, a pair of files or a folder (docs/file-formats.md): an OpenCV FileStorage
YAML/XML file, OpenCV stereo_calib's intrinsics.yml + extrinsics.yml, ROS camera_info left.yaml
+ right.yaml (+ an OpenCV file with R and T when they hold no baseline), a Kalibr camchain.yaml,
MATLAB stereoParameters as JSON or as a MAT-file (.mat, toStruct saved with -v7), or a RoboCal
stereo.yaml. E, F and the rectification are
computed where the files leave them out; the reprojection errors and the checkerboard stay
unknown. The output is written atomically. A rig the marker location cannot use (the cameras
one above the other, or the 'right' camera on the left) is converted with a note saying so.
"""
from __future__ import annotations

import argparse
from pathlib import Path

from app.commands import CommandResult, check_output

HELP = "Convert a stereo calibration from OpenCV, ROS, Kalibr or MATLAB into stereo.yaml"

INPUTS = ("sources=SOURCE",)      # checked against OUTPUTS before the run (app/commands/paths.py)
OUTPUTS = ("out",)

UNITS_MM = {"mm": 1.0, "cm": 10.0, "m": 1000.0, "in": 25.4}


def image_size(text: str) -> tuple[int, int]:
    """WxH in pixels, e.g. 1280x1024."""
    try:
        w, h = (int(v) for v in text.lower().split("x"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected WIDTHxHEIGHT in pixels (e.g. 1280x1024), got {text!r}") from None
    if not (0 < w <= 100_000 and 0 < h <= 100_000):
        raise argparse.ArgumentTypeError(f"expected 1 … 100000 px each, got {text!r}")
    return w, h


image_size.__name__ = "image size"


def add_arguments(parser) -> None:
    parser.add_argument("sources", nargs="+", metavar="SOURCE",
                        help="the calibration file(s), or the folder holding them: OpenCV YAML/XML, stereo_calib "
                             "intrinsics.yml + extrinsics.yml, ROS left.yaml + right.yaml, Kalibr camchain.yaml, "
                             "MATLAB stereoParameters .json or .mat (s = toStruct(stereoParams); "
                             "save('stereo.mat', 's', '-v7')), RoboCal stereo.yaml (docs/file-formats.md)")
    parser.add_argument("--out", required=True, metavar="stereo.yaml", help="RoboCal stereo calibration to write")
    parser.add_argument("--image-size", type=image_size, metavar="WxH",
                        help="image size in pixels, for files that do not hold it (OpenCV stereo_calib's); "
                             "default: inferred from the principal point, with a note")
    parser.add_argument("--unit", choices=sorted(UNITS_MM), default="mm",
                        help="length unit of an OpenCV file's T (the checkerboard square's unit; default mm)")


def run(args) -> CommandResult:
    from app.commands.paths import same_file
    from core.errors import RoboCalError, UsageError
    from core.stereo.file import stereo_json, write_stereo_yaml
    from core.stereo.importers import read_any_stereo
    from core.stereo.rectification import StereoRectification

    check_output(args.out, "--out")
    imported = read_any_stereo(args.sources, image_size=args.image_size, mm_per_unit=UNITS_MM[args.unit])
    for source in imported.sources:          # also the files found beside SOURCE or inside a folder
        if same_file(Path(args.out), source):
            raise UsageError(f"--out is the same file as the input {source}: the output would overwrite it; "
                             "choose another --out")
    path = write_stereo_yaml(args.out, imported.file)
    sf = imported.file
    lines = [f"Wrote {path} from {imported.kind} ({', '.join(p.name for p in imported.sources)}): "
             f"{sf.image_size[0]}x{sf.image_size[1]} px, baseline {sf.baseline_mm:.2f} mm; reprojection errors "
             f"and checkerboard unknown." if sf.rms_stereo is None else
             f"Wrote {path} from {imported.kind}: {sf.image_size[0]}x{sf.image_size[1]} px, baseline "
             f"{sf.baseline_mm:.2f} mm, stereo RMS {sf.rms_stereo:.3f} px."]
    try:
        StereoRectification.from_calibration(sf)
    except RoboCalError as exc:
        imported.notes.append(f"the marker location will refuse this calibration: {exc.problem}. {exc.hint}")
    lines += [f"  note: {n}" for n in imported.notes]
    data = {"out": str(path), "source_format": imported.kind, "sources": [str(p) for p in imported.sources],
            "notes": imported.notes, "stereo": stereo_json(sf)}
    return CommandResult(text="\n".join(lines), data=data)
