"""`robocal export`: export a robot model as URDF, a DH table, or a Universal Robots arm's
kinematics calibration (the ur_description / ur_robot_driver YAML)."""
from __future__ import annotations

from app.commands import CommandResult, check_output

HELP = "Export a robot model as URDF, a DH table (CSV) or a UR kinematics calibration (YAML)"


INPUTS = ("robot",)      # checked against OUTPUTS before the run (app/commands/paths.py)
OUTPUTS = ("out",)


def add_arguments(parser) -> None:
    parser.add_argument("--robot", required=True, metavar="R.json", help="robot model file (e.g. a calibrated one)")
    parser.add_argument("--format", required=True, choices=["urdf", "dh-csv", "ur-kinematics"],
                        help="export format (ur-kinematics: the ur_description kinematics YAML of a UR arm)")
    parser.add_argument("--out", required=True, metavar="FILE", help="file to write")


def run(args) -> CommandResult:
    from core.identification.exports import export_model
    from core.robot.file import read_robot

    check_output(args.out, "--out")
    robot = read_robot(args.robot)
    if args.format == "ur-kinematics":
        from core.compensation.ur_kinematics import ur_kinematics, write_ur_kinematics

        path = write_ur_kinematics(robot, args.out, source=str(args.robot))
        off = ur_kinematics(robot).flange_offset[:3, 3]
        text = (f"Wrote {path} (UR kinematics for ur_description, robot '{robot.name}'); the calibrated flange "
                f"lies {float((off ** 2).sum() ** 0.5):.3f} mm from tool0: add the offset in the file's comment "
                "to the TCP.")
        return CommandResult(text=text, data={"format": args.format, "out": str(path), "robot": robot.name,
                                              "joints": robot.dof, "calibrated": robot.calibration is not None,
                                              "flange_offset_mm": [float(v) for v in off]})
    path = export_model(robot, args.format, args.out)
    return CommandResult(text=f"Wrote {path} ({args.format}, robot '{robot.name}').",
                         data={"format": args.format, "out": str(path), "robot": robot.name,
                               "joints": robot.dof, "calibrated": robot.calibration is not None})
