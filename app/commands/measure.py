"""`robocal measure`: a batch of pose image pairs -> a measurements file (target `marker`).

Images `DIR/left/*` and `DIR/right/*` are paired by sorted file name, and the k-th pair is
the k-th row of the joints file (header `pose,q1,...,qn`, degrees; mm for prismatic joints
when `--robot` says so). Each located marker is appended to `--out` at once (flushed to
disk); each pose that gives no point goes to `<out stem>.rejects.csv` (e.g. meas.rejects.csv)
with the reason. An existing output is continued with `--resume` (poses already measured or
rejected are skipped) or replaced with `--overwrite`; otherwise it is refused.
"""
from __future__ import annotations

import os
from pathlib import Path

from app.commands import CommandResult, ProgressLine
from app.commands.locate import add_locator_arguments

HELP = "Batch of pose image pairs to a measurements file (marker located in 3D per pose)"


INPUTS = ("stereo", "marker", "images", "joints", "robot")      # checked against OUTPUTS before the run (app/commands/paths.py)
OUTPUTS = ("out",)


def add_arguments(parser) -> None:
    add_locator_arguments(parser)
    parser.add_argument("--images", required=True, metavar="DIR", help="folder with left/ and right/ image folders")
    parser.add_argument("--joints", required=True, metavar="J.csv", help="joint values per pose (pose,q1,...,qn)")
    parser.add_argument("--out", required=True, metavar="meas.csv", help="measurements file to write")
    parser.add_argument("--robot", metavar="R.json", help="robot model: checks the joint count and joint types")
    group = parser.add_mutually_exclusive_group()
    group.add_argument("--resume", action="store_true", help="continue an existing output (skip poses done)")
    group.add_argument("--overwrite", action="store_true",
                       help="measure again into new files that replace the output and its rejects file "
                            "only when the run succeeds")
    parser.add_argument("--retry-rejected", action="store_true",
                        help="with --resume: measure the poses rejected in an earlier run again")


def run(args) -> CommandResult:
    from app.commands.locate import setup_locator
    from core.images import read_camera_image
    from core.stereo.image_files import pair_images
    from core.errors import RoboCalError, UsageError
    from core.measurement.run import rejects_path_for, run_measurements
    from core.poses.file import read_poses
    from core.robot.file import read_robot

    out = Path(args.out)
    if out.is_dir():
        raise UsageError(f"--out '{out}' is a folder; give a file name")
    rejects = rejects_path_for(out)
    existing = [p for p in (out, rejects) if p.exists() and p.stat().st_size > 0]
    if existing and not (args.resume or args.overwrite):
        raise RoboCalError("the output already exists", source=existing[0],
                           hint="Use --resume to continue it, --overwrite to start again, or another --out.")
    robot = read_robot(args.robot) if args.robot else None
    if robot is not None and "marker" not in robot.targets:
        raise RoboCalError("the robot model has no 'marker' target", source=args.robot,
                           hint='Add "targets": {"marker": [x, y, z]} (the marker centre in the tool frame).')
    poses = read_poses(args.joints, robot)
    images = Path(args.images)
    if not images.is_dir():
        raise RoboCalError("no such folder", source=images, hint="Give the folder holding left/ and right/.")
    pairs, _ = pair_images(images / "left", images / "right")
    if len(pairs) != len(poses):
        raise RoboCalError(f"{len(pairs)} image pairs in {images} but {len(poses)} poses in the joints file",
                           source=args.joints, hint="Give one row per image pair, in the order of the file names.")
    locator, _ = setup_locator(args)
    if args.retry_rejected and not args.resume:
        raise UsageError("--retry-rejected goes with --resume")
    # a new run writes beside the old files and replaces them only when it succeeds;
    # a run that measures nothing leaves no files behind (a plain re-run then just works)
    fresh = not args.resume
    write_out = out.with_name(f".{out.name}.new") if fresh else out
    write_rejects = rejects_path_for(write_out) if fresh else rejects
    if fresh:
        for p in (write_out, write_rejects):
            p.unlink(missing_ok=True)
    by_pose = {int(pid): pair for pid, pair in zip(poses.pose, pairs)}

    def capture_pose(pid, q):
        out_pair = []
        for side, path in zip(("left", "right"), by_pose[pid]):
            out_pair.append(read_camera_image(path, side, locator.rect.image_size))
        return tuple(out_pair)

    progress = ProgressLine("measure")
    try:
        result = run_measurements(poses, write_out, locate=locator.locate, capture_pose=capture_pose,
                                  rejects=write_rejects, resume=True, retry_rejected=args.retry_rejected,
                                  keep_locations=False, progress=progress)
        if fresh and not result.measured:
            raise _nothing_measured(result, len(poses))
    except RoboCalError as exc:
        if not fresh:
            raise
        for p in (write_out, write_rejects):
            p.unlink(missing_ok=True)
        named = {str(write_out): out, str(write_rejects): rejects}.get(exc.source)
        if named is None:
            raise
        # the user knows the file by its own name; its previous version is untouched
        hint = " ".join(h for h in ((exc.hint or "").rstrip(".") + ".", "The previous file is unchanged.") if h != ".")
        raise RoboCalError(exc.problem, source=named, field=exc.field, hint=hint) from None
    except BaseException:
        if fresh:
            for p in (write_out, write_rejects):
                p.unlink(missing_ok=True)
        raise
    finally:
        progress.close()
    if fresh:
        _replace(write_out, out)
        _replace(write_rejects, rejects)
    data = result.summary()
    data["points"] = [{"pose": o.pose, "x": float(o.point[0]), "y": float(o.point[1]), "z": float(o.point[2]),
                       "sigma": [float(v) for v in o.sigma] if o.sigma is not None else None}
                      for o in result.measured]
    n_new = len(result.measured)
    done_before = len(result.skipped)
    lines = [f"Measured {n_new} of {len(poses)} poses into {out}"
             + (f" ({done_before} done in an earlier run)" if done_before else "")
             + (f"; {len(result.rejected)} rejected, reasons in {rejects}:" if result.rejected else ".")]
    for o in result.rejected[:10]:
        lines.append(f"  pose {o.pose}: {o.reason}")
    if len(result.rejected) > 10:
        lines.append(f"  ... and {len(result.rejected) - 10} more")
    return CommandResult(text="\n".join(lines), data=data)


def _nothing_measured(result, n_poses: int) -> Exception:
    """The refusal of a new run that measured no pose: the most common reason, and no file written."""
    from collections import Counter
    from core.errors import RoboCalError
    reasons = Counter(o.reason for o in result.rejected)
    why = ""
    if reasons:
        reason, count = reasons.most_common(1)[0]
        why = f"; {count} of them: {reason}"
    return RoboCalError(f"none of the {n_poses} poses could be measured{why} (no file was written)",
                        hint="Check the stereo calibration and the marker image.")


def _replace(new: Path, old: Path) -> None:
    """Put a finished run's file in place of the old one (or remove the old one if the run wrote none)."""
    from core.errors import RoboCalError
    try:
        if new.exists():
            os.replace(new, old)
        else:
            old.unlink(missing_ok=True)
    except OSError as exc:
        raise RoboCalError(f"cannot replace the file ({exc.strerror})", source=old,
                           hint="The new measurements are in " + str(new)) from exc
