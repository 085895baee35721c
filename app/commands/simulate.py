"""`robocal simulate`: write a virtual-lab dataset (images, joints and the ground truth)."""
from __future__ import annotations


from app.commands import CommandResult, ProgressLine
from app.commands import options

HELP = "Write a virtual-lab dataset: checkerboard pairs, marker training image, pose images, joints, truth.json"


INPUTS = ("robot", "poses_file")      # checked against OUTPUTS before the run (app/commands/paths.py)
OUTPUTS = ("out",)


def add_arguments(parser) -> None:
    parser.add_argument("--out", required=True, metavar="DIR",
                        help="output folder (new, empty, or a previous dataset, which is replaced)")
    parser.add_argument("--robot", metavar="R.json",
                        help="nominal robot model file (default: the educational 6R preset)")
    parser.add_argument("--seed", type=options.seed, default=0, help="random seed; the same seed gives the same files (default 0)")
    parser.add_argument("--pairs", type=options.pair_count, default=20, help="checkerboard image pairs (default 20)")
    parser.add_argument("--poses", type=options.image_poses, default=40, help="robot poses with marker image pairs (default 40)")
    parser.add_argument("--poses-file", metavar="POSES.csv",
                        help="render these robot poses (a poses file, e.g. from select-poses) instead of --poses "
                             "random ones")
    parser.add_argument("--noise", type=options.noise_grey, default=0.5,
                        help="sensor read noise, grey levels (default 0.5; 0 for noise-free images)")


def run(args) -> CommandResult:
    from core.robot.file import read_robot
    from app.lab import simulate_dataset

    robot = read_robot(args.robot) if args.robot else None
    configurations = None
    if args.poses_file:
        from core.poses.file import read_poses
        from core.robot.model import robot_path
        from app.lab import DEFAULT_ROBOT
        configurations = read_poses(args.poses_file, robot or read_robot(robot_path(DEFAULT_ROBOT))).Q
    progress = ProgressLine("simulate")
    try:
        result = simulate_dataset(args.out, robot=robot, seed=args.seed, pairs=args.pairs, poses=args.poses,
                                  noise=args.noise, progress=progress, configurations=configurations)
    finally:
        progress.close()
    data = result.summary()
    text = (f"Wrote a virtual-lab dataset to {result.out_dir}: {_count(result.pairs, 'checkerboard pair')}, "
            f"{_count(result.poses, 'robot pose')}, marker/training.png, poses/joints.csv and truth.json "
            f"(robot: {result.robot_name}, seed {result.seed}).")
    return CommandResult(text=text, data=data)


def _count(n: int, noun: str) -> str:
    return f"{n} {noun}{'' if n == 1 else 's'}"
