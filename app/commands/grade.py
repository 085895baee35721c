"""`robocal grade`: a student's calibrated robot against the virtual lab's true robot (a mark
sheet), and the instructor's answer key of a lab seed."""
from __future__ import annotations

from app.commands import CommandResult, options
from core.errors import UsageError

HELP = "Mark a calibrated robot against the virtual lab's true robot (and write the answer key of a lab seed)"

INPUTS = ("student=STUDENT_CALIBRATED.json", "lab_robot", "stereo")      # checked against OUTPUTS (app/commands/paths.py)
OUTPUTS = ("answer_key",)

#: configurations the calibration never saw, rendered for the fresh-pose comparison
FRESH_POSES = 50
#: seed of the fresh poses' random stream (another stream than the dataset's)
FRESH_SEED = 9001


def add_arguments(parser) -> None:
    parser.add_argument("student", nargs="?", metavar="STUDENT_CALIBRATED.json",
                        help="the calibrated robot file to mark (written by robocal identify)")
    parser.add_argument("--lab-seed", type=options.seed, required=True,
                        help="seed of the virtual lab the data came from (simulate --seed)")
    parser.add_argument("--lab-robot", metavar="ROBOT.json",
                        help="robot the lab was built from (default: the educational 6R preset)")
    parser.add_argument("--stereo", metavar="S",
                        help="the student's stereo.yaml: its error against the lab's true cameras sets σ_stereo "
                             "(default: stereo.yaml beside the calibrated file, if there is one)")
    parser.add_argument("--fresh", type=options.pose_count, default=FRESH_POSES,
                        help=f"fresh poses for the accuracy comparison (default {FRESH_POSES})")
    parser.add_argument("--answer-key", metavar="OUT.json",
                        help="write the instructor's answer key of this lab seed (true parameters, what "
                             "cannot be compared and why, the fresh poses' true marker positions)")


def run(args) -> CommandResult:
    import numpy as np

    from app.lab import build_lab
    from core.files import atomic_write_json
    from core.identification.grading import grade_calibration
    from core.robot.file import read_robot

    if not args.student and not args.answer_key:
        raise UsageError("give the calibrated robot file to mark, or --answer-key OUT.json (or both)")
    lab = build_lab(read_robot(args.lab_robot) if args.lab_robot else None, args.lab_seed, 0.5)
    Q = lab.random_visible_poses(args.fresh, np.random.default_rng([FRESH_SEED, args.lab_seed]))
    data, text = {"lab_seed": args.lab_seed, "lab_robot": lab.nominal_robot.name}, []
    if args.answer_key:
        atomic_write_json(args.answer_key, _answer_key(lab, Q, args.lab_seed))
        data["answer_key"] = str(args.answer_key)
        text.append(f"wrote the answer key of lab seed {args.lab_seed} to {args.answer_key}")
    if args.student:
        student = read_robot(args.student)
        stereo = args.stereo or _beside(args.student, "stereo.yaml")
        shift = _stereo_shift(lab, stereo, Q) if stereo else None
        result = grade_calibration(student, lab.true_robot, Q, lab.target, stereo_shift=shift, source=args.student)
        data.update(result.to_dict(), stereo=stereo)
        text.insert(0, f"{args.student} against the virtual lab's true robot (seed {args.lab_seed}):\n"
                    + result.text())
    return CommandResult(text="\n".join(text), data=data)


def _beside(path, name: str) -> str | None:
    from pathlib import Path
    other = Path(path).parent / name
    return str(other) if other.is_file() else None


def _stereo_shift(lab, stereo_path, Q):
    """Where the student's stereo calibration puts the true marker positions at Q, minus them
    (mm, left camera frame): the lab's true cameras project them, the student's rig triangulates."""
    from core.marker.triangulation import triangulate_linear
    from core.stereo.file import read_stereo_yaml

    rig = read_stereo_yaml(stereo_path).rig
    truth = lab.true_robot.target_positions(Q, lab.target)
    left, right = lab.rig.project(truth)
    return triangulate_linear(rig, left, right) - truth


def _answer_key(lab, Q, seed: int) -> dict:
    """The truth of a lab seed in file units (mm, deg), with the reasons some parameters
    cannot be compared."""
    from core.identification.grading import ABSORBED_BY_BASE, BASE_OR_MARKER, LAST_JOINT
    from core.kinematics.jacobian import all_parameters
    from core.robot.file import robot_to_dict

    true, nominal = lab.true_robot, lab.nominal_robot
    rows = []
    for p in all_parameters(true, [lab.target]):
        if p.group != "joint":
            continue
        value, nom = (float(getattr(m.joints[p.joint], p.kind) * p.to_display) for m in (true, nominal))
        reason = (ABSORBED_BY_BASE if p.joint == 0 and p.kind in ("theta", "d") else
                  LAST_JOINT if p.joint == true.dof - 1 else "")
        rows.append({"name": p.name, "unit": p.unit, "true": value, "nominal": nom, "error": value - nom,
                     **({"not_compared": reason} if reason else {})})
    return {"format": "robocal.answer-key/1", "lab_seed": int(seed), "robot": nominal.name,
            "units": {"length": "mm", "angle": "deg"}, "parameters": rows,
            "base_and_marker": BASE_OR_MARKER, "true_robot": robot_to_dict(true),
            "fresh_poses": [{"q": [float(v) for v in true.q_to_file(q)],
                             "marker": [float(v) for v in true.target_position(q, lab.target)]} for q in Q]}
