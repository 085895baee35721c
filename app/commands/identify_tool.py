"""`robocal identify-tool`: identify a newly mounted tool's offsets from a few proposed poses with
the arm calibrated. `--poses-out` writes the poses to measure (with `--stereo`, only where both
cameras see the marker); they are then measured as pairs captured at them (`--joints --images
--stereo --marker`), by another instrument (`--measurements`), driven on the connected cell
(`--port --profile --cameras --stereo --marker`, the motion confirmed on the terminal or by
`--cell-clear`: app.commands.connected_cell), or on the virtual lab (`--lab`)."""
from __future__ import annotations

from app.commands import CommandResult, ProgressLine
from app.commands import connected_cell, options

HELP = "Identify a mounted tool's target offsets from a few proposed poses, the arm held at its calibration"

INPUTS = ("robot", "measurements", "lab_robot", "joints", "images", "stereo", "marker")
OUTPUTS = ("out", "poses_out")


def add_arguments(parser) -> None:
    parser.add_argument("--robot", required=True, metavar="CALIBRATED.json",
                        help="calibrated robot file whose \"tools\" define the tool")
    parser.add_argument("--tool", required=True, metavar="NAME", help="the tool mounted, by its name in \"tools\"")
    parser.add_argument("--out", metavar="UPDATED.json",
                        help="write the calibrated robot with the tool identified here")
    parser.add_argument("--poses-out", metavar="P.csv",
                        help="only write the proposed poses (deg / mm) to measure on the robot, then give "
                             "their measurements with --measurements")
    parser.add_argument("--measurements", metavar="M.csv",
                        help="measurements of the tool's targets at its poses (robocal measure, or another "
                             "instrument's after import-measurements)")
    parser.add_argument("--joints", metavar="P.csv", help="joint values of the captured poses (pose,q1..qn), one per "
                        "pair in --images")
    parser.add_argument("--images", metavar="DIR", help="folder with left/ and right/ pairs of the tool's poses")
    connected_cell.add_arguments(parser, port_help="the connected robot's serial port: the tool's proposed poses are "
                                 "driven there")
    parser.add_argument("--stereo", metavar="S", help="stereo calibration (pairs and the connected cell; with "
                        "--poses-out keep the poses both cameras see)")
    parser.add_argument("--marker", metavar="M", help="marker training image, description or trained marker")
    parser.add_argument("--marker-size", type=options.size_mm, metavar="MM", help="marker outer square side (mm)")
    parser.add_argument("--lab", action="store_true", help="measure on the virtual lab")
    parser.add_argument("--count", type=options.pose_count,
                        help="poses to propose (default: 5 for a tool with one target)")
    parser.add_argument("--lab-seed", type=options.seed,
                        help="seed of the virtual lab the robot was calibrated in (default 0; implies --lab)")
    parser.add_argument("--lab-robot", metavar="ROBOT.json",
                        help="robot file the virtual lab was built from, defining the tool (default: the "
                             "educational 6R preset; implies --lab)")
    parser.add_argument("--seed", type=options.seed, default=0, help="random seed of the poses and noise (default 0)")


def run(args) -> CommandResult:
    from app.jobs import tool as job
    from core.errors import UsageError
    from core.poses.file import write_poses
    from core.robot.file import read_robot
    from core.task import Monitor

    if args.poses_out is None and args.out is None:
        raise UsageError("give --out (the updated calibrated robot) or --poses-out (the poses to measure)")
    if args.poses_out is not None and args.out is not None:
        raise UsageError("--poses-out only proposes the poses to measure; give --out with --measurements (or on the "
                         "virtual lab) to identify the tool: one or the other")
    if args.poses_out is not None and args.measurements is not None:
        raise UsageError("--poses-out proposes the poses to measure; --measurements identifies from them: "
                         "one or the other")
    lab_asked = bool(args.lab or args.lab_seed is not None or args.lab_robot)
    sources = [k for k, v in (("pairs", args.joints or args.images), ("measurements", args.measurements),
                              ("port", connected_cell.given(args)), ("lab", lab_asked)) if v]
    if args.poses_out is not None and sources not in ([], ["lab"]):
        raise UsageError("--poses-out only proposes the poses to measure (with --stereo or the lab's cameras); "
                         "measure them in a second run")
    if len(sources) > 1:
        raise UsageError("give one place to measure: --joints/--images, --measurements, --port/--cameras or --lab")
    if args.poses_out is None and not sources:
        raise UsageError("say where the tool is measured: --joints P --images DIR (captured pairs), --measurements "
                         "M.csv, --port P --cameras L,R (the connected cell) or --lab (the virtual lab)")
    if sources == ["pairs"] and not (args.joints and args.images and args.stereo and args.marker):
        raise UsageError("captured pairs need --joints, --images, --stereo and --marker together")
    if sources == ["port"] and not (args.port and args.cameras and args.stereo and args.marker):
        raise UsageError("the connected cell needs --port, --cameras, --stereo and --marker together")
    if sources == ["port"]:
        connected_cell.require_confirmable(args)
    elif args.cell_clear:
        raise UsageError(f"{connected_cell.CELL_CLEAR} is for the connected cell (--port): nothing else moves a robot")
    progress = ProgressLine("identify-tool")
    monitor = Monitor(progress)
    try:
        if args.poses_out is not None:
            proposal = job.propose(args.robot, args.tool, lab_options=_options(args, lab_asked), count=args.count,
                                   seed=args.seed, progress=monitor)
            write_poses(args.poses_out, proposal.q_file)
            return CommandResult(
                text=f"Wrote {len(proposal.Q)} poses for tool '{args.tool}' to {args.poses_out}: measure its "
                     f"marker there, then run identify-tool with --joints/--images or --measurements.",
                data={"tool": args.tool, "poses": len(proposal.Q), "poses_out": str(args.poses_out)})
        if args.measurements is not None:
            where = f"measurement file {args.measurements}"
            update = job.identify_from_file(args.robot, args.tool, args.measurements, args.out, progress=monitor)
        elif sources == ["lab"]:
            from app.lab import build_lab
            lab = build_lab(read_robot(args.lab_robot) if args.lab_robot else None, args.lab_seed or 0, 0.5)
            where = f"the virtual lab (seed {args.lab_seed or 0})"
            update = job.identify_on_lab(args.robot, args.tool, lab, args.out, count=args.count, seed=args.seed,
                                         progress=monitor)
        else:
            where, update = _measured(args, job, monitor)
    finally:
        progress.close()
    result = update.identification
    return CommandResult(text=f"Measured on {where}. " + result.text() + f" Wrote {update.path}.",
                         data={**result.summary(), "out": str(update.path), "measured_on": where})


def _options(args, lab_asked: bool) -> dict:
    """Pose-choice options: the stereo calibration's cameras, the lab's, or none (joint limits only)."""
    if args.stereo:
        from app.jobs.check_sources import stereo_options
        return stereo_options(args.stereo, args.marker_size)
    if lab_asked:
        from app.lab import build_lab, lab_options
        from core.robot.file import read_robot
        return lab_options(build_lab(read_robot(args.lab_robot) if args.lab_robot else None, args.lab_seed or 0, 0.5))
    return {}


def _measured(args, job, monitor):
    """Captured pairs or the connected cell: (where, ToolUpdate)."""
    from app.commands.locate import setup_locator
    from app.jobs import check_sources
    from core.robot.file import read_robot

    model = read_robot(args.robot)
    target = model.tool_targets(args.tool)[0]
    locator = setup_locator(args)[0]
    if args.joints:
        poses = check_sources.image_files(model, args.joints, args.images, locator, target=target)
    else:
        proposal = job.propose(args.robot, args.tool, lab_options=_options(args, False), count=args.count,
                               seed=args.seed, progress=monitor.sub(0.0, 0.3))
        check_sources.require_within_limits(model, proposal.Q)       # before the question, not after a yes
        connected_cell.confirm_motion(args, f"{len(proposal.Q)} poses proposed for the tool '{args.tool}'")
        poses = check_sources.connected_cell(model, proposal.Q, args.port, args.profile, args.cameras, locator,
                                             target=target)
    with poses:
        meas = poses.measurements(model, progress=monitor.sub(0.3, 0.8))
    return poses.where, job.identify_from_measurements(args.robot, args.tool, meas, args.out,
                                                       progress=monitor.sub(0.8, 1.0))
