"""`robocal reidentify`: after a check out of limits whose diagnosis named one change, re-identify
that change from the check's own points (the last check in the log) and the new poses measured
for it (`robocal check --reid-poses` proposes them), the calibration as prior. The updated
calibrated robot is written (its history says what changed) only when the check of it at the
check's points is within limits; that check is appended to the log.

Exit 0 when the updated robot was written, 3 when its check stayed out of limits (nothing
written), 1 bad data, 2 usage.
"""
from __future__ import annotations

from app.commands import CommandResult, ProgressLine
from app.commands import options

HELP = "Re-identify the change a check found (tool, base or a joint's zero) from the check and a few new poses"
OUT_OF_LIMITS = 3

INPUTS = ("robot", "joints", "images", "stereo", "marker", "measurements")
OUTPUTS = ("out", "log")


def add_arguments(parser) -> None:
    parser.add_argument("--robot", required=True, metavar="CALIBRATED.json",
                        help="the calibrated robot file the check was made with")
    parser.add_argument("--log", required=True, metavar="CHECKS.csv",
                        help="the check log; its last check's points are used, the check of the updated robot is "
                             "appended")
    parser.add_argument("--change", required=True, metavar="KIND",
                        help="what changed, as the check's diagnosis named it: tool, base or jointK (K from 1)")
    parser.add_argument("--joints", metavar="R.csv", help="joint values of the new poses (pose,q1..qn), one per pair")
    parser.add_argument("--images", metavar="DIR", help="folder with left/ and right/ pairs of the new poses")
    parser.add_argument("--stereo", metavar="S", help="stereo calibration (with --images)")
    parser.add_argument("--marker", metavar="M", help="marker training image, description or trained marker")
    parser.add_argument("--marker-size", type=options.size_mm, metavar="MM", help="marker outer square side (mm)")
    parser.add_argument("--measurements", metavar="M.csv",
                        help="the new poses measured by another instrument (instead of --joints/--images)")
    parser.add_argument("--out", required=True, metavar="UPDATED.json", help="the updated calibrated robot file")


def run(args) -> CommandResult:
    from app.jobs import check as job
    from app.jobs import check_sources
    from core.errors import UsageError
    from core.robot.file import read_robot
    from core.task import Monitor

    pairs = [args.joints, args.images, args.stereo, args.marker]
    if args.measurements and any(pairs):
        raise UsageError("give the new poses as captured pairs (--joints --images --stereo --marker) or as "
                         "--measurements: one or the other")
    if not args.measurements and not all(pairs):
        raise UsageError("give the new poses: --joints R.csv --images DIR --stereo S --marker M, or --measurements "
                         "M.csv")
    model = read_robot(args.robot)
    progress = ProgressLine("reidentify")
    monitor = Monitor(progress)
    try:
        target = job.last_check(args.log, model).target
        if args.measurements:
            new = check_sources.measurement_file(model, args.measurements, target)
        else:
            from app.commands.locate import setup_locator
            new = check_sources.image_files(model, args.joints, args.images, setup_locator(args)[0], target=target)
        meas = new.measurements(model, progress=monitor.sub(0.0, 0.4))
        update = job.reidentify_measured(args.robot, args.log, args.change, meas, args.out,
                                         progress=monitor.sub(0.4, 1.0))
    finally:
        progress.close()
    re = update.reidentification
    change = ", ".join(f"{k} {v:+.3f}" for k, v in re.change().items())
    lines = [f"Measured the new poses on {new.where}.",
             f"Re-identified {', '.join(re.changed)} from {update.n_new} new poses and the check's "
             f"{re.n_poses - update.n_new} points: {change} (mm / deg); error {re.rms_before_mm:.3f} → "
             f"{re.rms_after_mm:.3f} mm RMS on them.",
             "Check of the updated robot at the check's points: " + update.after.verdict()]
    if update.path is not None:
        lines.append(f"Wrote {update.path}.")
    else:
        lines.append(f"{args.out} was not written: the updated robot is still out of limits; run a full calibration.")
    data = {"measured_on": new.where, "reidentification": re.summary(), "after": update.after.summary(),
            "in_limits": update.after.within, "out": str(update.path) if update.path else None}
    return CommandResult(text="\n".join(lines), data=data, exit_code=0 if update.path is not None else OUT_OF_LIMITS)
