"""`robocal import-measurements`: joint values and measured positions from a laser tracker or
another tool (CSV, columns in any order) as a RoboCal measurements file."""
from __future__ import annotations

from app.commands import CommandResult, check_output

HELP = "Convert a CSV of joint values and measured positions (laser tracker, another tool) to measurements.csv"

INPUTS = ("csv=the CSV file", "robot")      # checked against OUTPUTS before the run (app/commands/paths.py)
OUTPUTS = ("out",)


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


def run(args) -> CommandResult:
    from core.measurement.file import write_measurements
    from core.measurement.importer import import_measurements
    from core.robot.file import read_robot

    check_output(args.out, "--out")
    robot = read_robot(args.robot) if args.robot else None
    imported = import_measurements(args.csv, length_unit=args.length_unit, angle_unit=args.angle_unit,
                                   target=args.target, robot=robot)
    meas = imported.measurements
    path = write_measurements(meas, args.out)
    targets = meas.target_names
    lines = [f"Wrote {path}: {meas.n_points} points, {meas.n_poses} poses, {meas.dof} joints, "
             f"targets {', '.join(targets)}."] + [f"  note: {n}" for n in imported.notes]
    return CommandResult(text="\n".join(lines),
                         data={"out": str(path), "points": meas.n_points, "poses": meas.n_poses, "joints": meas.dof,
                               "targets": targets, "notes": imported.notes})
