"""`robocal stereo-calibrate`: stereo calibration from checkerboard image pairs.

Pairs are matched by sorted file name. `--left`/`--right` take a folder, a (quoted) glob
pattern such as 'data/left*.jpg', or the image files themselves; `--pairs DIR` takes one folder
of both cameras' images named leftNN / rightNN. Bad pairs are skipped
with a reason; when too few usable pairs remain, one line names the files and reasons,
the exit code is 1 and no file is written (a previous stereo.yaml stays as it was).
"""
from __future__ import annotations

from pathlib import Path

from app.commands import CommandResult, ProgressLine, check_output
from app.commands import options
from core.stereo.board import Board
from core.stereo.screening import detect_folders
from core.errors import UsageError
from core.task import Monitor
from core.stereo.calibration import StereoCalibrationResult, calibrate_stereo
from core.stereo.fit import CalibrationOptions
from core.files import atomic_write_many
from core.stereo.file import ros_camera_info_files, stereo_json_text, stereo_yaml_text

HELP = "Stereo calibration from checkerboard image pairs (matched by sorted file name)"


INPUTS = ("left", "right", "pairs")      # checked against OUTPUTS before the run (app/commands/paths.py)
OUTPUTS = ("out", "export_json", "ros/left.yaml", "ros/right.yaml")


def add_arguments(parser) -> None:
    parser.add_argument("--left", nargs="+", metavar="DIR",
                        help="left camera images: a folder, a quoted pattern like 'dir/left*.jpg', or files")
    parser.add_argument("--right", nargs="+", metavar="DIR",
                        help="right camera images (same forms as --left)")
    parser.add_argument("--pairs", metavar="DIR",
                        help="instead of --left/--right: one folder of both cameras' images named leftNN and rightNN "
                             "(as OpenCV's stereo samples)")
    parser.add_argument("--board", required=True, metavar="COLSxROWS",
                        help="inner corners of the checkerboard, e.g. 9x6")
    parser.add_argument("--square", required=True, type=options.size_mm, metavar="MM", help="square size in mm")
    parser.add_argument("--out", default="stereo.yaml", metavar="FILE",
                        help="calibration file to write (default: stereo.yaml)")
    parser.add_argument("--radial", type=int, choices=(2, 3, 6), default=3,
                        help="radial distortion coefficients: 2, 3 (default) or 6 (rational model)")
    parser.add_argument("--no-tangential", action="store_true", help="no tangential distortion (p1 = p2 = 0)")
    parser.add_argument("--fix-aspect", action="store_true", help="keep fx = fy")
    parser.add_argument("--fix-principal", action="store_true", help="keep the principal point at the image centre")
    parser.add_argument("--fix-intrinsics", action="store_true",
                        help="keep each camera's own intrinsics in the stereo fit (default: refine them jointly)")
    parser.add_argument("--exclude", metavar="LIST", default="",
                        help="pairs to leave out: numbers (1 = first pair in sorted order) or file names, "
                             "comma-separated")
    parser.add_argument("--outlier-k", type=options.outlier_k, default=3.0, metavar="K",
                        help="flag pairs whose error exceeds median + K·sigma (default 3)")
    parser.add_argument("--ros", metavar="DIR", help="also write ROS camera_info files left.yaml and right.yaml here")
    parser.add_argument("--export-json", metavar="FILE", help="also write the full result as JSON")


def _source(values: list[str]):
    return values[0] if len(values) == 1 else values


def _parse_exclude(text: str, detections) -> list[int]:
    out = []
    for item in (t.strip() for t in text.split(",")):
        if not item:
            continue
        if item.isdigit():
            n = int(item)
            if not 1 <= n <= len(detections.pairs):
                raise UsageError(f"--exclude: pair {n} does not exist (there are {len(detections.pairs)} pairs)")
            out.append(n - 1)
            continue
        hits = [p.index for p in detections.pairs if item in (Path(p.left_path).name, Path(p.right_path).name)]
        if not hits:
            raise UsageError(f"--exclude: no pair has an image named '{item}'")
        out.extend(hits)
    return out


def _image_sources(args) -> tuple:
    """(left, right) image sources: --left/--right, or --pairs' folder given for both (pair_images
    tells its images apart by name)."""
    if args.pairs is not None:
        if args.left or args.right:
            raise UsageError("give either --pairs DIR or --left and --right, not both")
        return args.pairs, args.pairs
    if not args.left or not args.right:
        raise UsageError("give the images: --left DIR --right DIR, or --pairs DIR for one folder of leftNN/rightNN "
                         "images")
    return _source(args.left), _source(args.right)


def run(args) -> CommandResult:
    left, right = _image_sources(args)
    board = Board.parse(args.board, args.square)
    options = CalibrationOptions(radial=args.radial, tangential=not args.no_tangential,
                                 fix_aspect=args.fix_aspect, fix_principal=args.fix_principal,
                                 refine_intrinsics=not args.fix_intrinsics, outlier_k=args.outlier_k).validate()
    check_output(args.out, "--out")
    check_output(args.export_json, "--export-json")
    if args.ros:
        for name in ("left.yaml", "right.yaml"):
            check_output(str(Path(args.ros) / name), "--ros", folder_given=True)
    progress = ProgressLine("stereo-calibrate")
    try:
        detections = detect_folders(left, right, board, progress=Monitor(progress).sub(0, 0.6))
        exclude = _parse_exclude(args.exclude, detections)
        result = calibrate_stereo(detections, options, exclude=exclude, progress=Monitor(progress).sub(0.6, 1.0))
    finally:
        progress.close()
    files = {Path(args.out): stereo_yaml_text(result)}          # all written, or none changed
    if args.ros:
        files.update(ros_camera_info_files(args.ros, result))
    if args.export_json:
        files[Path(args.export_json)] = stereo_json_text(result)
    written = [str(p) for p in atomic_write_many(files)]
    data = result.summary()
    data["files_written"] = written
    data["ignored_files"] = list(detections.ignored_files)
    return CommandResult(text=_text(result, written, detections.ignored_files), data=data)


def _text(r: StereoCalibrationResult, written: list[str], ignored: list[str]) -> str:
    s = r.std
    lines = [f"stereo calibration: {r.pairs_used} pairs used, {len(r.rejected)} rejected, "
             f"{len(r.excluded)} excluded ({r.options.describe()})",
             f"  reprojection RMS: left {r.file.rms_left:.3f} px, right {r.file.rms_right:.3f} px, "
             f"stereo {r.file.rms_stereo:.3f} px",
             f"  epipolar error after rectification: RMS {r.epipolar_rms:.3f} px, max {r.epipolar_max:.3f} px"]
    cv = r.cross_validation
    if cv is not None:
        lines.append(f"  cross-validation (two halves): {cv.rms_observed_px:.3f} px RMS where the boards were, "
                     f"{cv.rms_px:.3f} px RMS / {cv.max_px:.2f} px max over the whole image")
    for side, K in (("left", r.file.K1), ("right", r.file.K2)):
        lines.append(f"  {side + ' camera:':<14}fx {K[0, 0]:.2f} ± {s.get('fx_' + side, 0):.2f}  "
                     f"fy {K[1, 1]:.2f} ± {s.get('fy_' + side, 0):.2f}  cx {K[0, 2]:.2f} ± {s.get('cx_' + side, 0):.2f}  "
                     f"cy {K[1, 2]:.2f} ± {s.get('cy_' + side, 0):.2f} px")
    T = r.file.T
    lines.append(f"  baseline {r.baseline_mm:.2f} ± {s.get('baseline', 0):.2f} mm, "
                 f"T = ({T[0]:.2f}, {T[1]:.2f}, {T[2]:.2f}) mm")
    if r.coverage is not None:
        c = r.coverage
        lines.append(f"  coverage: X {c.x:.2f}  Y {c.y:.2f}  size {c.size:.2f}  skew {c.skew:.2f} "
                     f"({'enough views' if c.enough else 'not enough views'})")
    for index, name, reason in r.rejected:
        lines.append(f"  rejected pair {index + 1} ({name}): {reason}")
    for index in r.excluded:
        lines.append(f"  excluded pair {index + 1}")
    for index, what in r.reordered:
        lines.append(f"  pair {index + 1}: {what}")
    for name in ignored:
        lines.append(f"  ignored: {name}")
    for w in r.warnings:
        lines.append(f"  warning: {w}")
    lines.append("wrote " + ", ".join(written))
    return "\n".join(lines)
