"""`robocal check`: check a calibrated cell on the virtual lab, diagnose a change, re-identify.

Exit code 0 when the check of the given robot is within its limits, 3 when it is out of limits
(also when a re-identification then brought it back; 1 bad data, 2 usage).
"""
from __future__ import annotations

from app.commands import CommandResult, ProgressLine
from app.commands import options
from core.bounds import Bound

HELP = "Check a calibrated robot at its check poses, diagnose a change and re-identify it (exit 3: out of limits)"
OUT_OF_LIMITS = 3
ALPHA = Bound(1e-4, 0.2, "", "a false-alarm probability")
SIGMA = Bound(1e-4, 10.0, "mm", "a measurement noise per axis")

INPUTS = ("robot", "poses", "stereo", "marker", "lab_robot")      # checked against OUTPUTS before the run (app/commands/paths.py)
OUTPUTS = ("log", "out")


def add_arguments(parser) -> None:
    parser.add_argument("--robot", required=True, metavar="CALIBRATED.json",
                        help="calibrated robot file (written by robocal identify or a previous re-identification)")
    parser.add_argument("--log", required=True, metavar="CHECKS.csv", help="check log; every point is appended")
    parser.add_argument("--poses", metavar="P.csv", help="check poses (default: chosen by observability)")
    parser.add_argument("--count", type=options.pose_count, default=8,
                        help="check poses to choose when --poses is not given (default 8)")
    parser.add_argument("--tool", metavar="NAME",
                        help="the tool mounted, by its name in the robot file's \"tools\" (default: the first "
                             "calibrated tool); check poses, predictions and limits use its target")
    parser.add_argument("--lab-seed", type=options.seed, default=0,
                        help="seed of the virtual lab the robot was calibrated in (default 0)")
    parser.add_argument("--lab-robot", metavar="ROBOT.json",
                        help="robot file the virtual lab was built from (default: the educational 6R preset); "
                             "the lab can mount the tools it defines")
    parser.add_argument("--stereo", metavar="S", help="stereo calibration: measure through rendered images "
                        "(with --marker); without it the lab's ideal measurements are used")
    parser.add_argument("--marker", metavar="M", help="marker training image, description or trained marker")
    parser.add_argument("--marker-size", type=options.size_mm, metavar="MM", help="marker outer square side (mm)")
    parser.add_argument("--noise", type=options.number_in(SIGMA), default=0.05, metavar="MM",
                        help="noise of the lab's ideal measurements, mm per axis (default 0.05)")
    parser.add_argument("--change", metavar="SPEC",
                        help="change the lab's true robot first: tool:MM, base:MM, jointK:DEG, linkK:MM, or "
                             "mount:NAME (another tool mounted than --tool)")
    parser.add_argument("--alpha", type=options.number_in(ALPHA), default=0.01,
                        help="false-alarm probability of a check (default 0.01)")
    parser.add_argument("--out", metavar="UPDATED.json",
                        help="when the check is out of limits and one change explains it: re-identify it from "
                             "the proposed poses and write the updated calibrated robot here")
    parser.add_argument("--seed", type=options.seed, default=0, help="random seed of measurements (default 0)")


def run(args) -> CommandResult:
    from app.jobs import check as job
    from app.lab import apply_change, build_lab, ideal_measure, image_measure, lab_options, parse_change
    from core.errors import UsageError
    from core.robot.file import read_robot
    from core.task import Monitor

    if bool(args.stereo) != bool(args.marker):
        raise UsageError("--stereo and --marker go together (images), or neither (ideal measurements)")
    change = parse_change(args.change) if args.change else None
    progress = ProgressLine("check")
    monitor = Monitor(progress)
    try:
        lab = build_lab(read_robot(args.lab_robot) if args.lab_robot else None, args.lab_seed, 0.5)
        opts = lab_options(lab)
        cell = job.setup(args.robot, lab_options=opts, poses_path=args.poses, count=args.count, alpha=args.alpha,
                         seed=args.seed, tool=args.tool, progress=monitor.sub(0.0, 0.3))
        if cell.target not in lab.nominal_robot.targets:
            raise UsageError(f"the virtual lab's robot has no target '{cell.target}' of the tool '{cell.tool}'",
                             hint="Give --lab-robot the robot file that defines the tool.")
        lab.target = cell.target                    # the technician mounted the tool checked
        if change is not None:
            apply_change(lab, change, seed=args.seed)
        if args.stereo:
            from app.commands.locate import setup_locator
            measure = image_measure(lab, setup_locator(args)[0].locate, seed=args.seed)
        else:
            measure = ideal_measure(lab, sigma_mm=args.noise, seed=args.seed)
        result, diagnosis = job.check(cell, measure, log=args.log, progress=monitor.sub(0.3, 0.7))
        update = None
        if diagnosis is not None and args.out and diagnosis.explained:
            update = job.reidentify_from_proposed(cell, result, diagnosis, measure, args.out, lab_options=opts,
                                                  log=args.log, seed=args.seed, progress=monitor.sub(0.7, 1.0))
    finally:
        progress.close()
    lines = [result.verdict()]
    data = {"check": result.summary(), "tool": cell.tool, "change": str(change) if change else None}
    if diagnosis is not None:
        lines.append(diagnosis.text)
        data["diagnosis"] = diagnosis.summary()
    if update is not None:
        lines.append(f"Re-identified {', '.join(update.reidentification.changed)} from {len(update.proposed)} "
                     f"proposed poses and the check: wrote {update.path}. Check of the updated robot: "
                     + update.after.verdict())
        data["reidentification"] = update.reidentification.summary()
        data["after"] = update.after.summary()
    elif diagnosis is not None and args.out:
        lines.append(f"{args.out} was not written: no single change explains the check.")
    return CommandResult(text="\n".join(lines), data=data, exit_code=0 if result.within else OUT_OF_LIMITS)
