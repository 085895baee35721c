"""`robocal robustness`: where the marker method breaks in the virtual lab.

Renders marker pairs under dimmer light, with part of the marker covered and with the marker
tilted away from the cameras, locates the marker in each (the lab's marker trained on its
training image, the lab's true cameras, so the figures are the marker method's alone) and
prints, per condition value, the detection rate, the median and 95th-percentile 3D error
against the truth and how many markers were accepted more than 2 mm off (silent wrong
numbers; exit code 1 if there are any). Without --light, --occlusion or --tilt all three are
swept at their default values; with some of them, only those.
"""
from __future__ import annotations

from app.commands import CommandResult, ProgressLine
from app.commands import options
from core.bounds import Bound

HELP = "Detection rate and 3D error of the marker under dim light, occlusion and tilt (virtual lab)"

INPUTS = ("robot",)
OUTPUTS = ()

LIGHT = Bound(0.01, 1.5, "", "a gain on the scene's light: 1 is the lab's normal light")
OCCLUSION = Bound(0.0, 0.9, "", "a fraction of the marker's outer square")
TILT = Bound(0.0, 85.0, "degrees", "the angle between the marker's normal and the view")
PAIRS = Bound(1, 1_000, "", "pairs rendered per condition value")


def _values(bound: Bound):
    one = options.number_in(bound)

    def parse(text: str) -> tuple[float, ...]:
        return tuple(one(part) for part in text.split(",") if part.strip()) or (one(text),)
    parse.__name__ = "list of numbers"
    return parse


def add_arguments(parser) -> None:
    parser.add_argument("--robot", metavar="R.json",
                        help="nominal robot model file (default: the educational 6R preset)")
    parser.add_argument("--seed", type=options.seed, default=0, help="random seed of the lab and the views (default 0)")
    parser.add_argument("--noise", type=options.noise_grey, default=0.5,
                        help="sensor read noise, grey levels (default 0.5)")
    parser.add_argument("--pairs", type=options.whole_in(PAIRS), default=20,
                        help="stereo pairs per condition value (default 20)")
    parser.add_argument("--light", type=_values(LIGHT), metavar="G,G,...",
                        help="light levels, gains on the scene (default 1,0.7,0.5,0.3,0.2,0.1)")
    parser.add_argument("--occlusion", type=_values(OCCLUSION), metavar="F,F,...",
                        help="fractions of the marker's outer square covered (default 0,0.1,0.2,0.3,0.4,0.5)")
    parser.add_argument("--side", choices=("left", "right", "top", "bottom", "corner"), default="corner",
                        help="where the occluder covers the marker: a band from one side (hides one edge of "
                             "the square) or a patch over a corner (default corner)")
    parser.add_argument("--tilt", type=_values(TILT), metavar="DEG,DEG,...",
                        help="tilts of the marker from facing the cameras, degrees (default 0,20,40,50,60,70,75)")


def run(args) -> CommandResult:
    from app import lab as L
    from core.marker.location import MarkerLocator
    from core.marker.training import train_marker
    from core.robot.file import read_robot
    from core.stereo.rectification import StereoRectification

    chosen = [args.light, args.occlusion, args.tilt]
    light, occlusion, tilt = (L.LIGHT, L.OCCLUSION, L.TILT) if all(v is None for v in chosen) else \
        tuple(v or () for v in chosen)
    robot = read_robot(args.robot) if args.robot else None
    progress = ProgressLine("robustness")
    try:
        lab = L.build_lab(robot, args.seed, args.noise)
        trained = train_marker(lab.render_training_image(), outer_size=lab.marker.outer_size)
        locator = MarkerLocator(trained, StereoRectification.from_rig(lab.rig))
        table = L.robustness_sweep(lab, locator, light=light, occlusion=occlusion, tilt=tilt, pairs=args.pairs,
                                   seed=args.seed, side=args.side, progress=progress)
    finally:
        progress.close()
    data = table.to_dict()
    data.update(robot=lab.nominal_robot.name, noise=args.noise)
    text = table.text()
    if table.wrong:
        text += (f"\n{table.wrong} marker(s) accepted more than {table.wrong_mm:g} mm from the truth: the locator's "
                 "checks let a wrong point through.")
    return CommandResult(text=text, data=data, exit_code=1 if table.wrong else 0)
