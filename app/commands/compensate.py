"""`robocal compensate`: corrected programs with the calibrated model.

From Cartesian targets (--targets, in the base, camera or a fixture frame) or a nominal joint
program (--program with --nominal), the joints that put the calibrated robot where they mean,
written as a joints file (`pose,q1..qn`, read by `measure --joints`, the Measurement page and
the robot drivers), a G-code program for a GRBL joint arm, or a RoboCal-protocol move list;
or, with --for-controller cartesian, the Cartesian targets to give a controller that keeps its
nominal kinematics. Every point must be reachable inside the joint limits, otherwise nothing is
written and the first failing point is named.
"""
from __future__ import annotations

from app.commands import CommandResult, ProgressLine, check_output

HELP = "Correct a program (Cartesian targets or nominal joints) with the calibrated robot model"

INPUTS = ("robot", "targets", "program", "nominal", "frame")
OUTPUTS = ("out",)

FORMATS = ("joints", "gcode", "moves")


def add_arguments(parser) -> None:
    parser.add_argument("--robot", required=True, metavar="CALIBRATED.json", help="calibrated robot file")
    source = parser.add_mutually_exclusive_group(required=True)
    source.add_argument("--targets", metavar="T.csv",
                        help="Cartesian targets: name,x,y,z[,roll,pitch,yaw][,q1..qn] (mm, degrees)")
    source.add_argument("--program", metavar="NOMINAL_JOINTS.csv",
                        help="a joint program (pose,q1..qn) made with the nominal model (needs --nominal)")
    parser.add_argument("--nominal", metavar="ROBOT.json",
                        help="the nominal robot model the controller (and --program) uses")
    parser.add_argument("--frame", default="base", metavar="base|camera|FIXTURE_POSE.json",
                        help="frame of --targets: the robot's base (default), the left camera, or a fixture pose "
                             "file written by locate-fixture")
    parser.add_argument("--tcp", default="marker", metavar="NAME",
                        help="the tool point: a target of the robot (default marker) or 'tool' (the tool frame)")
    parser.add_argument("--position-only", action="store_true",
                        help="reach the positions only, ignoring roll, pitch, yaw (or the program's orientations)")
    parser.add_argument("--for-controller", choices=["cartesian"],
                        help="write corrected Cartesian targets for a controller with nominal kinematics")
    parser.add_argument("--format", default="joints", choices=FORMATS,
                        help="joints file (default), gcode (GRBL joint arm) or moves (RoboCal protocol)")
    parser.add_argument("--out", required=True, metavar="FILE", help="file to write")


def _frame(value: str, calibrated):
    """'base', 'camera' or a fixture pose file's frame (4x4 in the base frame)."""
    from core.errors import UsageError
    from pathlib import Path

    if value in ("base", "camera", "measurement"):
        return value, value
    if not Path(value).suffix.lower() == ".json":
        raise UsageError(f"--frame '{value}' is not base, camera or a fixture pose file (.json)")
    from core.fixtures.file import read_fixture_pose

    pose = read_fixture_pose(value)
    return pose.frame.matrix, f"fixture '{pose.name}' ({value})"


def run(args) -> CommandResult:
    from core.compensation.controller_program import write_controller_program
    from core.compensation.program import compensate_program, compensate_targets
    from core.compensation.targets import read_targets, write_targets
    from core import transforms as tf
    from core.errors import RoboCalError, UsageError
    from core.poses.file import read_pose_list, write_poses
    from core.robot.file import read_robot
    from core.task import Monitor

    import numpy as np

    if args.program and not args.nominal:
        raise UsageError("--program needs --nominal: the robot model the program was made with")
    if args.for_controller and not args.nominal:
        raise UsageError("--for-controller cartesian needs --nominal: the kinematics the controller keeps")
    if args.for_controller and args.format != "joints":
        raise UsageError("--for-controller cartesian writes Cartesian targets; leave out --format")
    if args.program and args.frame != "base":
        raise UsageError("--frame applies to --targets only (a joint program has no frame)")
    check_output(args.out, "--out")
    calibrated = read_robot(args.robot)
    nominal = read_robot(args.nominal) if args.nominal else None
    progress = ProgressLine("compensate")
    try:
        if args.targets:
            frame, frame_text = _frame(args.frame, calibrated)
            targets = read_targets(args.targets, calibrated.dof)
            result = compensate_targets(calibrated, targets, tcp=args.tcp, frame=frame, nominal=nominal,
                                        orientation=not args.position_only, progress=Monitor(progress))
            source = args.targets
        else:
            frame_text = "base"
            program = read_pose_list(args.program, nominal)
            result = compensate_program(calibrated, nominal, program.Q, tcp=args.tcp,
                                        names=[str(p) for p in program.pose], orientation=not args.position_only,
                                        progress=Monitor(progress))
            source = args.program
    finally:
        progress.close()
    failures = result.failures()
    if failures:
        i, why = failures[0]
        more = f" ({len(failures)} of {len(result.names)} points fail)" if len(failures) > 1 else ""
        raise RoboCalError(f"point '{result.names[i]}' cannot be reached: {why}{more}", source=source,
                           hint="Move the point inside the robot's reach and joint limits, or give q columns "
                                "nearer the wanted configuration; nothing was written.")
    if args.for_controller:
        poses = result.controller_poses()
        rpy = np.rad2deg([tf.matrix_to_rpy(T[:3, :3]) for T in poses]).reshape(-1, 3)
        nominal_q = nominal.q_to_file(result.Q).reshape(result.Q.shape)
        path = write_targets(args.out, result.names, poses[:, :3, 3], rpy, nominal_q)
        what = f"corrected Cartesian targets for a controller with the kinematics of '{nominal.name}' (base frame)"
    elif args.format == "joints":
        path = write_poses(args.out, result.q_file, decimals=6)
        what = "corrected joints (pose,q1..qn)"
    else:
        path = write_controller_program(args.out, calibrated, result.Q, result.names, args.format,
                                        source=str(source))
        what = {"gcode": "G-code program for a GRBL joint arm", "moves": "RoboCal-protocol move list"}[args.format]
    where = (f"Targets in the {frame_text} frame." if args.targets
             else "The poses the nominal program meant, in the robot's base frame.")
    text = f"{result.summary()} {where} Wrote {path}: {what}."
    data = {"robot": str(args.robot), "calibrated": calibrated.name, "nominal": str(args.nominal or ""),
            "source": str(source), "frame": frame_text, "tcp": args.tcp, "out": str(path),
            "format": "cartesian" if args.for_controller else args.format,
            "orientation": bool(result.ik.orientation), "points": result.table()}
    if result.predicted is not None:
        data["predicted_probability"] = result.predicted.probability
    return CommandResult(text=text, data=data)
