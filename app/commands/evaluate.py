"""`robocal evaluate`: position errors of a robot model against measurements."""
from __future__ import annotations

from app.commands import CommandResult, options

HELP = "Position errors of a robot model against measurements"


INPUTS = ("robot", "measurements", "place")      # checked against OUTPUTS before the run (app/commands/paths.py)
OUTPUTS = ()


def add_arguments(parser) -> None:
    parser.add_argument("--robot", required=True, metavar="R.json", help="robot model file (e.g. a calibrated one)")
    parser.add_argument("--measurements", required=True, metavar="M.csv", help="measurements file")
    parser.add_argument("--register-base", action="store_true",
                        help="first fit the base pose by rigid registration (for a model whose base "
                             "pose in the camera frame is not known, e.g. a nominal one)")
    parser.add_argument("--place", metavar="ONCE.csv",
                        help="measurements file of targets the robot file lacks, each measured in one pose (e.g. a "
                             "reflector mounted after calibration): they are placed on the tool before the errors "
                             "are computed; by the model alone unless --relative-to is given")
    parser.add_argument("--relative-to", type=options.target_names, metavar="TARGETS",
                        help="with --place: calibrated target(s) measured in the same pose as each new one "
                             "(comma-separated); the new target is placed from the difference of the two "
                             "measurements, so the model's own error at that pose cancels")


def run(args) -> CommandResult:
    from core.errors import UsageError
    from core.identification.placement import place_targets
    from core.identification.fit import evaluate
    from core.measurement.file import read_measurements
    from core.robot.file import read_robot

    if args.relative_to and not args.place:
        raise UsageError("--relative-to needs --place ONCE.csv (the measurements of the new targets)")
    robot = read_robot(args.robot)
    placed = []
    if args.place:
        robot, placed = place_targets(robot, read_measurements(args.place, robot), references=args.relative_to or ())
    meas = read_measurements(args.measurements, robot)
    stats = evaluate(robot, meas, register=args.register_base)
    data = stats.summary()
    if placed:
        data["placed"] = [p.summary() for p in placed]
    data["per_pose"] = stats.per_pose()
    data["per_point"] = stats.per_point()
    worst = max(data["per_pose"], key=lambda p: p["error_mm"])
    text = (f"{stats.n} points in {len(data['per_pose'])} poses: mean {stats.mean_mm:.4f} mm, "
            f"RMS {stats.rms_mm:.4f} mm, max {stats.max_mm:.4f} mm (worst pose {worst['pose']}: "
            f"{worst['error_mm']:.4f} mm)" + (" with the base pose registered." if args.register_base else "."))
    for p in placed:
        text += (f"\n  {p.name} placed {p.how} from pose {', '.join(str(i) for i in p.poses)}: "
                 f"({', '.join(f'{v:.3f}' for v in p.offset)}) mm on the tool")
    return CommandResult(text=text, data=data)
