"""`robocal export`: export a robot model as URDF or a DH table."""
from __future__ import annotations

from app.commands import CommandResult, check_output

HELP = "Export a robot model as URDF or a DH table (CSV)"


INPUTS = ("robot",)      # checked against OUTPUTS before the run (app/commands/paths.py)
OUTPUTS = ("out",)


def add_arguments(parser) -> None:
    parser.add_argument("--robot", required=True, metavar="R.json", help="robot model file (e.g. a calibrated one)")
    parser.add_argument("--format", required=True, choices=["urdf", "dh-csv"], help="export format")
    parser.add_argument("--out", required=True, metavar="FILE", help="file to write")


def run(args) -> CommandResult:
    from core.identification.exports import export_model
    from core.robot.file import read_robot

    check_output(args.out, "--out")
    robot = read_robot(args.robot)
    path = export_model(robot, args.format, args.out)
    return CommandResult(text=f"Wrote {path} ({args.format}, robot '{robot.name}').",
                         data={"format": args.format, "out": str(path), "robot": robot.name,
                               "joints": robot.dof, "calibrated": robot.calibration is not None})
