"""`robocal robot-import`: a nominal robot model (DH + base + tool) from a URDF serial chain."""
from __future__ import annotations

from app.commands import CommandResult, check_output

HELP = "Make a nominal robot model (robot.json) from a URDF serial chain"

INPUTS = ("urdf=the URDF file",)      # checked against OUTPUTS before the run (app/commands/paths.py)
OUTPUTS = ("out",)


def add_arguments(parser) -> None:
    parser.add_argument("urdf", metavar="robot.urdf", help="URDF file (metres and radians)")
    parser.add_argument("--base", metavar="LINK", help="base link of the chain (default: the URDF's root link)")
    parser.add_argument("--tip", metavar="LINK", help="tip link (default: the one end link that moves)")
    parser.add_argument("--out", required=True, metavar="robot.json", help="robot model to write")
    parser.add_argument("--target", nargs=4, metavar=("NAME", "X", "Y", "Z"),
                        help="a target point in the tool frame, mm (e.g. marker 0 0 50)")


def run(args) -> CommandResult:
    from core.bounds import LENGTH_MM
    from core.errors import RoboCalError, UsageError
    from core.robot.file import write_robot
    from core.robot.urdf_import import import_urdf
    from core.validate import name_text

    check_output(args.out, "--out")
    imported = import_urdf(args.urdf, base=args.base, tip=args.tip)
    model = imported.model
    if args.target:
        name, *xyz = args.target
        try:
            values = [LENGTH_MM.check(float(v), field="--target") for v in xyz]
        except ValueError:
            raise UsageError(f"--target needs NAME X Y Z with numbers in mm, got {' '.join(args.target)}") from None
        try:
            name_text(name, None, "--target")
        except RoboCalError as exc:
            raise UsageError(exc.message) from None
        model.targets[name] = values
    path = write_robot(model, args.out)
    lines = [f"Wrote {path}: '{model.name}', {model.dof} joints from '{imported.base_link}' to "
             f"'{imported.tip_link}' ({', '.join(j.name for j in model.joints)})."]
    lines += [f"  note: {n}" for n in imported.notes]
    return CommandResult(text="\n".join(lines), data={
        "out": str(path), "name": model.name, "joints": [j.name for j in model.joints],
        "base_link": imported.base_link, "tip_link": imported.tip_link, "notes": imported.notes})
