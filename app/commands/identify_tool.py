"""`robocal identify-tool`: identify a newly mounted tool's offsets from a few proposed poses with
the arm calibrated: measured on the virtual lab, or from the measurements of those poses made
on the robot (`--poses-out` writes them to measure first)."""
from __future__ import annotations

from app.commands import CommandResult, ProgressLine
from app.commands import options

HELP = "Identify a mounted tool's target offsets from a few proposed poses, the arm held at its calibration"

INPUTS = ("robot", "measurements", "lab_robot")
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
                        help="measurements of the tool's targets at its poses (default: measured on the virtual lab)")
    parser.add_argument("--count", type=options.pose_count,
                        help="poses to propose (default: 5 for a tool with one target)")
    parser.add_argument("--lab-seed", type=options.seed, default=0,
                        help="seed of the virtual lab the robot was calibrated in (default 0)")
    parser.add_argument("--lab-robot", metavar="ROBOT.json",
                        help="robot file the virtual lab was built from, defining the tool (default: the "
                             "educational 6R preset)")
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
    progress = ProgressLine("identify-tool")
    monitor = Monitor(progress)
    try:
        if args.measurements is not None:
            update = job.identify_from_file(args.robot, args.tool, args.measurements, args.out, progress=monitor)
        else:
            from app.lab import build_lab, lab_options
            lab = build_lab(read_robot(args.lab_robot) if args.lab_robot else None, args.lab_seed, 0.5)
            if args.poses_out is not None:
                proposal = job.propose(args.robot, args.tool, lab_options=lab_options(lab), count=args.count,
                                       seed=args.seed, progress=monitor)
                write_poses(args.poses_out, proposal.q_file)
                return CommandResult(
                    text=f"Wrote {len(proposal.Q)} poses for tool '{args.tool}' to {args.poses_out}: measure its "
                         f"marker there, then run identify-tool with --measurements.",
                    data={"tool": args.tool, "poses": len(proposal.Q), "poses_out": str(args.poses_out)})
            update = job.identify_on_lab(args.robot, args.tool, lab, args.out, count=args.count, seed=args.seed, progress=monitor)
    finally:
        progress.close()
    result = update.identification
    return CommandResult(text=result.text() + f" Wrote {update.path}.",
                         data={**result.summary(), "out": str(update.path)})
