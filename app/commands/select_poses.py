"""`robocal select-poses`: a pose sequence chosen by observability.

With `--stereo S` (or `--virtual-lab`) only configurations that put the marker in view of
both cameras are candidates; the robot file's base pose must then be given in the left
camera frame (the measurement frame): a calibrated model written by `robocal identify`, or
the virtual lab's placed robot (`--virtual-lab` places it itself).
"""
from __future__ import annotations

import math

from app.commands import CommandResult, check_output
from app.commands import options

HELP = "Pose sequence chosen by observability (condition number or O1/O3/O4/O5 of the calibration Jacobian)"


INPUTS = ("robot", "stereo")      # checked against OUTPUTS before the run (app/commands/paths.py)
OUTPUTS = ("out",)


def add_arguments(parser) -> None:
    parser.add_argument("--robot", metavar="R.json",
                        help="robot model file (with --stereo its base pose must be in the left camera frame)")
    parser.add_argument("--count", required=True, type=options.pose_count, metavar="N", help="number of poses to select")
    parser.add_argument("--out", required=True, metavar="poses.csv", help="pose sequence to write (pose,q1..qn; degrees)")
    parser.add_argument("--candidates", type=options.candidates, default=2000, metavar="M",
                        help="feasible candidate configurations to choose from (default 2000)")
    parser.add_argument("--index", default="cond", choices=["cond", "O1", "O3", "O4", "O5"],
                        help="observability index to optimise (default cond, the condition number)")
    source = parser.add_mutually_exclusive_group()
    source.add_argument("--stereo", metavar="S",
                        help="stereo calibration (stereo.yaml, another tool's file or a folder holding one): keep "
                             "only poses where both cameras see the marker")
    source.add_argument("--virtual-lab", action="store_true",
                        help="use the virtual lab's cameras, placed robot and table (robot from --robot or the demo arm)")
    parser.add_argument("--lab-seed", type=options.seed, default=0, help="seed of the virtual lab (default 0, as the demo)")
    parser.add_argument("--seed", type=options.seed, default=0, help="seed of the candidate poses (default 0)")
    parser.add_argument("--margin", type=options.angle_deg, default=5.0, metavar="DEG",
                        help="keep this far from every joint limit (degrees; mm for prismatic joints; default 5)")
    parser.add_argument("--plate", type=options.size_mm, metavar="MM",
                        help="marker plate side for the visibility check with --stereo (default: the default marker's)")
    parser.add_argument("--max-angle", type=options.angle_deg, default=60.0, metavar="DEG",
                        help="largest angle between the marker normal and each camera direction (default 60)")
    parser.add_argument("--min-depth", type=options.depth_mm, metavar="MM", help="smallest marker depth (default 350; lab 400)")
    parser.add_argument("--max-depth", type=options.depth_mm, metavar="MM", help="largest marker depth (default 1000; lab 900)")
    parser.add_argument("--random-trials", type=options.random_trials, default=100, metavar="K",
                        help="random selections of the same size to compare with (default 100)")


def run(args) -> CommandResult:
    from core.errors import UsageError
    from core.poses.candidates import VisibilityOptions
    from app.lab import lab_options
    from core.poses.selection import select_poses, write_selection
    from core.robot.file import read_robot

    if args.candidates < args.count:
        raise UsageError(f"--candidates ({args.candidates}) must be at least --count ({args.count})")
    if args.robot is None and not args.virtual_lab:
        raise UsageError("--robot is required (or --virtual-lab for the demo arm)")
    options: dict = {}
    if args.virtual_lab:
        from app.lab import VirtualLab

        lab = VirtualLab.create(read_robot(args.robot) if args.robot else None, seed=args.lab_seed)
        options = lab_options(lab)
        robot = options.pop("robot")
    else:
        robot = read_robot(args.robot)
        if args.stereo:
            from core.marker.description import MarkerDescription
            from core.stereo.importers import read_any_stereo

            options["rig"] = read_any_stereo(args.stereo).file.rig
            options["plate_size"] = (args.plate, args.plate) if args.plate else tuple(MarkerDescription.default().plate_size)
            options["visibility"] = VisibilityOptions()
    vis = options.get("visibility")
    if vis is not None:
        vis.max_angle_deg = args.max_angle
        if args.min_depth is not None:
            vis.min_depth = args.min_depth
        if args.max_depth is not None:
            vis.max_depth = args.max_depth
        if not 0 <= vis.min_depth < vis.max_depth:
            raise UsageError(f"the depth range {vis.min_depth:g}–{vis.max_depth:g} mm is empty")
    check_output(args.out, "--out")
    result = select_poses(robot, args.count, candidates=args.candidates, index=args.index, seed=args.seed,
                          margin=args.margin, random_trials=args.random_trials, **options)
    write_selection(result, args.out)
    return CommandResult(text=_text(result), data=result.as_dict())


def _fmt(v) -> str:
    return "-" if v is None or (isinstance(v, float) and not math.isfinite(v)) else f"{v:.4g}"


def _text(r) -> str:
    from core.poses.selection import INDEX_KEYS, INDEXES

    c = r.candidates
    rejected = ", ".join(f"{k} {v}" for k, v in c.rejected.items() if v) or "none"
    lines = [f"Selected {r.count} poses by {r.index} from {len(c)} candidates "
             f"({c.drawn} configurations drawn; rejected: {rejected}).",
             f"  {len(r.parameters)} identifiable parameters; at least {r.n_min} poses needed, "
             f"{r.recommended} recommended.",
             f"  {'index':<6} {'selected':>10} {'random median':>14}   ({r.random.trials} random selections of {r.count})"]
    sel = r.indices.as_dict()
    for k in INDEXES:
        lines.append(f"  {k:<6} {_fmt(sel[INDEX_KEYS[k]]):>10} {_fmt(r.random.median[k]):>14}")
    lines.append(f"  Travel from home: {r.travel_before:.0f} -> {r.travel_after:.0f} deg after ordering "
                 f"(largest joint move per step, summed).")
    for w in r.warnings:
        lines.append(f"  Note: {w}.")
    lines.append(f"Wrote {r.path}.")
    return "\n".join(lines)
