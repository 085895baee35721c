"""`robocal evaluate`: position errors of a robot model against measurements."""
from __future__ import annotations

from app.commands import CommandResult

HELP = "Position errors of a robot model against measurements"


INPUTS = ("robot", "measurements")      # checked against OUTPUTS before the run (app/commands/paths.py)
OUTPUTS = ()


def add_arguments(parser) -> None:
    parser.add_argument("--robot", required=True, metavar="R.json", help="robot model file (e.g. a calibrated one)")
    parser.add_argument("--measurements", required=True, metavar="M.csv", help="measurements file")
    parser.add_argument("--register-base", action="store_true",
                        help="first fit the base pose by rigid registration (for a model whose base "
                             "pose in the camera frame is not known, e.g. a nominal one)")


def run(args) -> CommandResult:
    from core.identification.solver import evaluate
    from core.measurement.file import read_measurements
    from core.robot.file import read_robot

    robot = read_robot(args.robot)
    meas = read_measurements(args.measurements, robot)
    stats = evaluate(robot, meas, register=args.register_base)
    data = stats.summary()
    data["per_pose"] = stats.per_pose()
    data["per_point"] = stats.per_point()
    worst = max(data["per_pose"], key=lambda p: p["error_mm"])
    text = (f"{stats.n} points in {len(data['per_pose'])} poses: mean {stats.mean_mm:.4f} mm, "
            f"RMS {stats.rms_mm:.4f} mm, max {stats.max_mm:.4f} mm (worst pose {worst['pose']}: "
            f"{worst['error_mm']:.4f} mm)" + (" with the base pose registered." if args.register_base else "."))
    return CommandResult(text=text, data=data)
