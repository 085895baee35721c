"""`robocal import-measurements`: joint values and measured positions from a laser tracker or
another tool (CSV, columns in any order) as a RoboCal measurements file."""
from __future__ import annotations

from app.commands import CommandResult, check_output, options

HELP = "Convert a CSV of joint values and measured positions (laser tracker, another tool) to measurements.csv"

INPUTS = ("csv=the CSV file", "robot")      # checked against OUTPUTS before the run (app/commands/paths.py)
OUTPUTS = ("out", "placed_robot")


def add_arguments(parser) -> None:
    parser.add_argument("csv", nargs="+", metavar="CSV",
                        help="CSV file(s): pose, target, q1..qn, x, y, z in any order (see docs/file-formats.md)")
    parser.add_argument("--out", required=True, metavar="measurements.csv", help="measurements file to write")
    parser.add_argument("--length-unit", choices=["mm", "m"],
                        help="unit of positions and prismatic joints where a column does not say (default mm)")
    parser.add_argument("--angle-unit", choices=["deg", "rad"],
                        help="unit of revolute joints where a column does not say (default deg)")
    parser.add_argument("--target", default="marker",
                        help="target name of every row when the file has no target column (default marker)")
    parser.add_argument("--robot", metavar="R.json",
                        help="robot model: checks the joint count and says which joints are prismatic")
    parser.add_argument("--placed-robot", metavar="R.json",
                        help="with --robot: also write the robot with every target of the file it lacks placed on "
                             "the tool (each measured in one pose); by the model alone unless --relative-to is given")
    parser.add_argument("--relative-to", type=options.target_names, metavar="TARGETS",
                        help="with --placed-robot: calibrated target(s) measured in the same pose as each new one "
                             "(comma-separated); the new target is placed from the difference of the measurements")


def run(args) -> CommandResult:
    from core.errors import UsageError
    from core.identification.placement import place_targets
    from core.measurement.file import write_measurements
    from core.measurement.importer import import_measurements
    from core.robot.file import read_robot, write_robot

    check_output(args.out, "--out")
    if args.placed_robot and not args.robot:
        raise UsageError("--placed-robot needs --robot R.json (the calibrated robot the targets are placed on)")
    if args.relative_to and not args.placed_robot:
        raise UsageError("--relative-to needs --placed-robot R.json (the robot file to write)")
    if args.placed_robot:
        check_output(args.placed_robot, "--placed-robot")
    robot = read_robot(args.robot) if args.robot else None
    imported = import_measurements(args.csv, length_unit=args.length_unit, angle_unit=args.angle_unit,
                                   target=args.target, robot=robot)
    meas = imported.measurements
    placed, placed_robot = [], None
    if args.placed_robot:
        placed_robot, placed = place_targets(robot, meas, references=args.relative_to or ())
    path = write_measurements(meas, args.out)
    targets = meas.target_names
    lines = [f"Wrote {path}: {meas.n_points} points, {meas.n_poses} poses, {meas.dof} joints, "
             f"targets {', '.join(targets)}."] + [f"  note: {n}" for n in imported.notes]
    data = {"out": str(path), "points": meas.n_points, "poses": meas.n_poses, "joints": meas.dof,
            "targets": targets, "notes": imported.notes}
    if placed_robot is not None:
        write_robot(placed_robot, args.placed_robot)
        lines.append(f"Wrote {args.placed_robot}: the robot with {', '.join(p.name for p in placed)} placed on the tool.")
        lines += [f"  {p.name} placed {p.how} from pose {', '.join(str(i) for i in p.poses)}: "
                  f"({', '.join(f'{v:.3f}' for v in p.offset)}) mm" for p in placed]
        data["placed_robot"] = str(args.placed_robot)
        data["placed"] = [p.summary() for p in placed]
    return CommandResult(text="\n".join(lines), data=data)
