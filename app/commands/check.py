"""`robocal check`: check a calibrated cell at its check poses, diagnose a change, propose the
poses that re-identify it.

Where it measures, one of:
- `--joints J.csv --images DIR --stereo S --marker M`: pairs captured at the check poses
  (`DIR/left`, `DIR/right`, as `robocal measure` reads them);
- `--measurements M.csv`: points measured by another instrument (or by `robocal measure`);
- `--port PORT --profile P --cameras L,R --stereo S --marker M`: the connected cell, the robot
  driven to each check pose once its motion is confirmed: asked on a terminal, or `--cell-clear`
  for an unattended run from cron or a systemd timer (app.commands.connected_cell);
- `--lab` (or any `--lab-…` / `--change` option): the virtual lab, for teaching.
`--propose-poses P.csv` only writes the check poses (a joints file) and measures nothing.

Exit code 0 when the check is within its limits, 3 when it is out of limits (also when a
re-identification then brought it back; 1 bad data or a robot fault, 2 usage).
"""
from __future__ import annotations

from app.commands import CommandResult, ProgressLine, check_output
from app.commands import connected_cell, options
from core.bounds import Bound

HELP = "Check a calibrated robot at its check poses, diagnose a change and re-identify it (exit 3: out of limits)"
OUT_OF_LIMITS = 3
ALPHA = Bound(1e-4, 0.2, "", "a false-alarm probability")
SIGMA = Bound(1e-4, 10.0, "mm", "a measurement noise per axis")

INPUTS = ("robot", "poses", "stereo", "marker", "lab_robot", "joints", "images", "measurements", "place")
OUTPUTS = ("log", "out", "propose_poses", "reid_poses")


def add_arguments(parser) -> None:
    parser.add_argument("--robot", required=True, metavar="CALIBRATED.json",
                        help="calibrated robot file (written by robocal identify or a previous re-identification)")
    parser.add_argument("--log", metavar="CHECKS.csv", help="check log; every point is appended (needed to check)")
    parser.add_argument("--propose-poses", metavar="POSES.csv",
                        help="only write the check poses to this joints file (pose,q1..qn; deg / mm), chosen by "
                             "observability; with --stereo only where both cameras see the marker")
    parser.add_argument("--poses", metavar="P.csv", help="check poses for the lab or the connected robot "
                        "(default: chosen by observability)")
    parser.add_argument("--count", type=options.pose_count, default=8,
                        help="check poses to choose when they are not given (default 8)")
    parser.add_argument("--tool", metavar="NAME",
                        help="the tool mounted, by its name in the robot file's \"tools\" (default: the first "
                             "calibrated tool); check poses, predictions and limits use its target")
    parser.add_argument("--payload", type=options.payload_kg, metavar="KG",
                        help="the mass mounted on the flange now (kg); compared with the payload the calibration "
                             "recorded, for which its deflection terms hold")
    parser.add_argument("--place", metavar="ONCE.csv",
                        help="measurements file of targets the robot file lacks, each measured in one pose: they are "
                             "placed on the tool before the check (by the model alone unless --relative-to is given) "
                             "and the check measures the first of them, its limits with the placement's uncertainty")
    parser.add_argument("--relative-to", type=options.target_names, metavar="TARGETS",
                        help="with --place: calibrated target(s) measured in the same pose as each new one "
                             "(comma-separated); the new target is placed from the difference of the two "
                             "measurements, so the model's own error at that pose cancels")
    files = parser.add_argument_group("measured outside RoboCal: captured pairs or another instrument")
    files.add_argument("--joints", metavar="POSES.csv", help="joint values of the captured check poses "
                       "(pose,q1..qn), one per pair in --images")
    files.add_argument("--images", metavar="DIR", help="folder with left/ and right/ image folders (with --joints)")
    files.add_argument("--measurements", metavar="M.csv",
                       help="measurements file of the check poses (robocal measure, or import-measurements)")
    connected_cell.add_arguments(parser, port_help="the robot controller's serial port (e.g. /dev/ttyUSB0): the "
                                 "check poses (and with --out the re-identification's) are driven there")
    parser.add_argument("--stereo", metavar="S", help="stereo calibration: locate the marker in the pairs (with "
                        "--marker); with --propose-poses, keep poses both cameras see")
    parser.add_argument("--marker", metavar="M", help="marker training image, description or trained marker")
    parser.add_argument("--marker-size", type=options.size_mm, metavar="MM", help="marker outer square side (mm)")
    lab = parser.add_argument_group("the virtual lab (teaching)")
    lab.add_argument("--lab", action="store_true", help="measure on the virtual lab")
    lab.add_argument("--lab-seed", type=options.seed, help="seed of the virtual lab the robot was calibrated in "
                     "(default 0; implies --lab)")
    lab.add_argument("--lab-robot", metavar="ROBOT.json",
                     help="robot file the virtual lab was built from (default: the educational 6R preset; implies "
                          "--lab); the lab can mount the tools it defines")
    lab.add_argument("--noise", type=options.number_in(SIGMA), default=0.05, metavar="MM",
                     help="noise of the lab's ideal measurements, mm per axis (default 0.05), without --stereo")
    lab.add_argument("--change", metavar="SPEC",
                     help="change the lab's true robot first (implies --lab): tool:MM, base:MM, jointK:DEG, linkK:MM, "
                          "or mount:NAME (another tool mounted than --tool)")
    parser.add_argument("--alpha", type=options.number_in(ALPHA), default=0.01,
                        help="false-alarm probability of a check (default 0.01)")
    parser.add_argument("--reid-poses", metavar="R.csv",
                        help="when the check is out of limits and one change explains it: write the poses to "
                             "measure for its re-identification (then robocal reidentify)")
    parser.add_argument("--out", metavar="UPDATED.json",
                        help="lab or connected robot: when one change explains the check, measure the proposed "
                             "poses, re-identify it and write the updated calibrated robot here")
    parser.add_argument("--seed", type=options.seed, default=0, help="random seed of choices and lab noise (default 0)")


def _source(args) -> str:
    """Which of the measuring inputs was given (UsageError when none or several)."""
    lab = bool(args.lab or args.lab_seed is not None or args.lab_robot or args.change)
    given = {"images": bool(args.images or args.joints), "measurements": bool(args.measurements),
             "port": connected_cell.given(args), "lab": lab}
    chosen = [k for k, v in given.items() if v]
    if args.propose_poses:
        if chosen and chosen != ["lab"]:
            raise _usage("--propose-poses only writes the check poses; measure them afterwards with --joints/--images, "
                         "--measurements or --port")
        return "propose"
    if len(chosen) > 1:
        raise _usage("give one place to measure: --joints/--images, --measurements, --port/--cameras or --lab")
    if not chosen:
        raise _usage("say where to measure: --joints J --images DIR (captured pairs), --measurements M.csv, "
                     "--port P --cameras L,R (the connected cell) or --lab (the virtual lab); or --propose-poses "
                     "to write the check poses")
    return chosen[0]


def _usage(text: str):
    from core.errors import UsageError
    return UsageError(text)


def _validate(args, source: str) -> None:
    if source != "propose" and not args.log:
        raise _usage("--log CHECKS.csv is required to check (every point is appended to it)")
    if source == "images" and not (args.images and args.joints and args.stereo and args.marker):
        raise _usage("captured pairs need --joints, --images, --stereo and --marker together")
    if source == "port" and not (args.port and args.cameras and args.stereo and args.marker):
        raise _usage("the connected cell needs --port, --cameras, --stereo and --marker together")
    if source == "port":
        connected_cell.require_confirmable(args)
    elif args.cell_clear:
        raise _usage(f"{connected_cell.CELL_CLEAR} is for the connected cell (--port): nothing else moves a robot")
    if source == "lab" and bool(args.stereo) != bool(args.marker):
        raise _usage("--stereo and --marker go together (images), or neither (ideal measurements)")
    if source in ("images", "measurements") and args.out:
        raise _usage("--out re-identifies by measuring the proposed poses, which needs the lab or the connected "
                     "robot; with files write them with --reid-poses, then run robocal reidentify")
    if source in ("images", "measurements", "propose") and args.poses:
        raise _usage("--poses gives the poses to drive (lab or connected robot); captured pairs take theirs from "
                     "--joints, a measurements file from its rows")
    if args.relative_to and not args.place:
        raise _usage("--relative-to needs --place ONCE.csv (the measurements of the new targets)")
    if source == "propose" and (args.reid_poses or args.out):
        raise _usage("--propose-poses measures nothing, so there is nothing to re-identify")


def run(args) -> CommandResult:
    from app.jobs import check as job
    from core.task import Monitor

    source = _source(args)
    _validate(args, source)
    progress = ProgressLine("check")
    monitor = Monitor(progress)
    robot, placed = _robot(args)
    target = placed[0].name if placed else None         # the check measures the target placed
    try:
        if source == "propose":
            return _propose(args, job, monitor, robot, target)
        if source == "lab":
            run_check = _lab
        elif source == "port":
            run_check = _port
        else:
            run_check = _files
        where, cell, result, diagnosis, update, options_ = run_check(args, job, monitor, robot, target)
        reid = None
        if diagnosis is not None and diagnosis.explained and diagnosis.parameters and args.reid_poses:
            from core.poses.file import write_poses
            check_output(args.reid_poses, "--reid-poses")
            reid = job.propose_reidentification(cell, result, diagnosis, options=options_, seed=args.seed,
                                                progress=monitor.sub(0.9, 1.0))
            write_poses(args.reid_poses, reid.q_file)
    finally:
        progress.close()
    return _result(args, where, cell, result, diagnosis, update, reid, placed)


def _robot(args):
    """The calibrated robot, with the targets of --place placed on the tool with their uncertainty
    (and how each was)."""
    from core.identification.placement import place_targets
    from core.measurement.file import read_measurements
    from core.monitoring.uncertainty import calibration_uncertainty
    from core.robot.file import read_robot

    robot = read_robot(args.robot)
    if not args.place:
        return robot, []
    return place_targets(robot, read_measurements(args.place, robot), references=args.relative_to or (),
                         uncertainty=calibration_uncertainty(robot, source=args.robot))


def _propose(args, job, monitor, robot, target) -> CommandResult:
    from core.poses.file import write_poses
    from app.jobs.check_sources import stereo_options

    check_output(args.propose_poses, "--propose-poses")
    opts = stereo_options(args.stereo, args.marker_size) if args.stereo else {}
    if not args.stereo and (args.lab or args.lab_seed is not None or args.lab_robot):
        opts = _lab_options(args)[1]
    cell = job.setup(args.robot, lab_options=opts, count=args.count, alpha=args.alpha, seed=args.seed, tool=args.tool,
                     model=robot, target=target, progress=monitor)
    write_poses(args.propose_poses, cell.model.q_to_file(cell.Q))
    seen = ("both cameras of the stereo calibration see the marker" if args.stereo
            else "the virtual lab's cameras see the marker" if opts else "no camera given: joint limits only")
    return CommandResult(text=f"Wrote {len(cell.Q)} check poses for tool '{cell.tool}' to {args.propose_poses} "
                              f"({seen}): capture a pair at each, then run robocal check with --joints and --images.",
                         data={"poses": len(cell.Q), "propose_poses": str(args.propose_poses), "tool": cell.tool,
                               "visibility": seen})


def _lab_options(args):
    from app.lab import build_lab, lab_options
    from core.robot.file import read_robot
    lab = build_lab(read_robot(args.lab_robot) if args.lab_robot else None, args.lab_seed or 0, 0.5)
    return lab, lab_options(lab)


def _locator(args):
    from app.commands.locate import setup_locator
    return setup_locator(args)[0]


def _lab(args, job, monitor, robot, target):
    from app.lab import apply_change, ideal_measure, image_measure, parse_change
    from core.errors import UsageError

    change = parse_change(args.change) if args.change else None
    lab, opts = _lab_options(args)
    cell = job.setup(args.robot, lab_options=opts, poses_path=args.poses, count=args.count, alpha=args.alpha,
                     seed=args.seed, tool=args.tool, model=robot, target=target, progress=monitor.sub(0.0, 0.3))
    if cell.target not in lab.nominal_robot.targets:
        raise UsageError(f"the virtual lab's robot has no target '{cell.target}' of the tool '{cell.tool}'",
                         hint="Give --lab-robot the robot file that defines the tool.")
    lab.target = cell.target                    # the technician mounted the tool checked
    if change is not None:
        apply_change(lab, change, seed=args.seed)
    if args.stereo:
        measure = image_measure(lab, _locator(args).locate, seed=args.seed)
        where = f"the virtual lab (seed {args.lab_seed or 0}), through rendered images"
    else:
        measure = ideal_measure(lab, sigma_mm=args.noise, seed=args.seed)
        where = f"the virtual lab (seed {args.lab_seed or 0}), ideal measurements"
    if change is not None:
        where += f", after the change {change}"
    result, diagnosis = job.check(cell, measure, log=args.log, progress=monitor.sub(0.3, 0.7))
    update = None
    if diagnosis is not None and args.out and diagnosis.explained and diagnosis.parameters:
        update = _reidentified(lambda: job.reidentify_from_proposed(
            cell, result, diagnosis, measure, args.out, lab_options=opts, log=args.log, seed=args.seed,
            progress=monitor.sub(0.7, 0.9)))
    return where, cell, result, diagnosis, update, opts


def _reidentified(run):
    """The Update of a re-identification, or the words why it wrote nothing (a RoboCalError other
    than a robot fault, which ends the command; a run the connected robot's fault cancelled: the
    caller raises that fault)."""
    from core.errors import Cancelled, RoboCalError
    from core.robot.driver import RobotFault
    try:
        return run()
    except RobotFault:
        raise
    except Cancelled:
        return "the robot stopped during the re-identification"
    except RoboCalError as exc:
        return f"{exc.problem}. {exc.hint or ''}".strip()


def _files(args, job, monitor, robot, target):
    from app.jobs import check_sources

    model = robot
    if args.measurements:
        unc = job.calibration_uncertainty(model, source=args.robot)
        _, target = job.mounted_tool(model, unc, args.tool, args.robot, target)
        poses = check_sources.measurement_file(model, args.measurements, target)
        opts = {}
    else:
        locator = _locator(args)
        poses = check_sources.image_files(model, args.joints, args.images, locator)
        opts = check_sources.stereo_options(args.stereo, args.marker_size)
    cell = job.setup(args.robot, Q=poses.Q, alpha=args.alpha, tool=args.tool, model=robot, target=target,
                     progress=monitor.sub(0.0, 0.1))
    result, diagnosis = _check_poses(job, cell, poses, args.log, monitor)
    return poses.where, cell, result, diagnosis, None, opts


def _check_poses(job, cell, poses, log, monitor):
    from core.monitoring.check import run_check
    from core.monitoring.diagnosis import diagnose

    result = run_check(cell.model, cell.unc, cell.Q, poses.measure, target=cell.target, tool=cell.tool,
                       pose_ids=poses.ids, log=log, alpha=cell.limits.alpha, limits=cell.limits,
                       progress=monitor.sub(0.1, 0.9), cancelled=poses.cancelled())
    poses.raise_fault()                 # a robot fault ended it: the points measured are in the log, exit 1
    diagnosis = diagnose(cell.model, cell.unc, result) if result.points and not result.within else None
    return result, diagnosis


def _port(args, job, monitor, robot, target):
    from app.jobs import check_sources

    opts = check_sources.stereo_options(args.stereo, args.marker_size)
    cell = job.setup(args.robot, lab_options=opts, poses_path=args.poses, count=args.count, alpha=args.alpha,
                     seed=args.seed, tool=args.tool, model=robot, target=target, progress=monitor.sub(0.0, 0.2))
    locator = _locator(args)
    reid = ", then to the poses that re-identify a change if one explains the check" if args.out else ""
    check_sources.require_within_limits(cell.model, cell.Q)        # before the question, not after a yes
    connected_cell.confirm_motion(args, f"{len(cell.Q)} check poses{reid}")
    with check_sources.connected_cell(cell.model, cell.Q, args.port, args.profile, args.cameras, locator,
                                      target=cell.target) as poses:
        result, diagnosis = _check_poses(job, cell, poses, args.log, monitor)
        update = None
        if diagnosis is not None and args.out and diagnosis.explained and diagnosis.parameters:
            update = _reidentified(lambda: job.reidentify_from_proposed(
                cell, result, diagnosis, poses.measure, args.out, lab_options=opts, log=args.log, seed=args.seed,
                progress=monitor.sub(0.7, 0.9), cancelled=poses.cancelled()))
            poses.raise_fault()
    return poses.where, cell, result, diagnosis, update, opts


def _payload(args, model) -> tuple[str | None, dict | None]:
    """One line comparing the declared payload (--payload) with the calibration's, and its JSON."""
    from app.jobs.check import payload_comparison
    return payload_comparison(args.payload, model)


def _result(args, where, cell, result, diagnosis, update, reid, placed) -> CommandResult:
    lines = [f"Measured on {where}.", result.verdict()]
    change = "none"
    if diagnosis is not None:
        change = ("unexplained" if not diagnosis.explained or diagnosis.kind not in ("tool", "base", "joint")
                  else f"joint{diagnosis.chosen.joint + 1}" if diagnosis.kind == "joint" else diagnosis.kind)
    data = {"in_limits": result.within, "change": change, "measured_on": where, "tool": cell.tool,
            "rms_mm": result.rms_mm, "rms_limit_mm": result.rms_limit_mm,
            "poses": [{"pose": p.pose, "error_mm": p.error_mm, "limit_mm": p.limit_mm, "within": p.within}
                      for p in result.points],
            "check": result.summary(), "lab_change": args.change}
    payload, data["payload"] = _payload(args, cell.model)
    if payload:
        lines.insert(1, payload)
    for p in placed:
        lines.append(f"{p.name} placed {p.how} from pose {', '.join(str(i) for i in p.poses)}: "
                     f"({', '.join(f'{v:.3f}' for v in p.offset)}) mm on the tool, σ {p.sigma_mm:.3f} mm per axis"
                     + (" (the target checked)" if p.name == cell.target else ""))
    if placed:
        data["placed"] = [p.summary() for p in placed]
    if diagnosis is not None:
        lines.append(diagnosis.text)
        data["diagnosis"] = diagnosis.summary()
    if reid is not None:
        lines.append(f"Wrote {len(reid.Q)} poses to measure for the re-identification to {args.reid_poses}: measure "
                     f"them, then run robocal reidentify --change {change}.")
        data["reid_poses"] = {"path": str(args.reid_poses), "poses": len(reid.Q)}
    elif diagnosis is not None and args.reid_poses:
        lines.append(f"{args.reid_poses} was not written: no single change explains the check.")
    if isinstance(update, str):
        lines.append(f"{args.out} was not written: {update}")
        data["reidentification_refused"] = update
    elif update is not None:
        n = len(update.proposed)
        lines.append(f"Re-identified {', '.join(update.reidentification.changed)} from {n} proposed "
                     f"pose{'s' if n != 1 else ''} and the check: wrote {update.path}. Check of the updated robot: "
                     + update.after.verdict())
        data["reidentification"] = update.reidentification.summary()
        data["after"] = update.after.summary()
    elif diagnosis is not None and args.out:
        lines.append(f"{args.out} was not written: no single change explains the check.")
    return CommandResult(text="\n".join(lines), data=data, exit_code=0 if result.within else OUT_OF_LIMITS)
