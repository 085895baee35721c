"""`robocal locate-fixture`: a fixture's frame in the robot's base frame from one stereo pair per
marker point, through the calibrated base transform; writes the fixture pose (JSON) and, with
--urdf, a URDF snippet (docs/file-formats.md).

The image pairs are LEFT RIGHT file names per point, in the fixture description's order, or one
folder holding left/<point name>.<ext> and right/<point name>.<ext> for every point.
"""
from __future__ import annotations

from app.commands import CommandResult, ProgressLine, check_output
from app.commands.locate import add_locator_arguments, setup_locator

HELP = "Locate a fixture (three or more marker points) in the robot's base frame and write its pose"

INPUTS = ("stereo", "marker", "calibrated", "fixture", "pairs=PAIR")
OUTPUTS = ("out", "urdf")


def add_arguments(parser) -> None:
    add_locator_arguments(parser)
    parser.add_argument("--calibrated", required=True, metavar="CALIBRATED.json",
                        help="calibrated robot file (robocal identify): the camera-to-base transform and its covariance")
    parser.add_argument("--fixture", required=True, metavar="FIXTURE.json",
                        help="fixture description: the marker points' names and nominal positions (mm)")
    parser.add_argument("pairs", nargs="+", metavar="PAIR",
                        help="LEFT RIGHT images of each point in the description's order, or one folder with "
                             "left/<name>.png and right/<name>.png per point")
    parser.add_argument("--out", required=True, metavar="FIXTURE_POSE.json", help="fixture pose file to write")
    parser.add_argument("--urdf", metavar="FIXTURE.urdf", help="also write the pose as a URDF fixed joint")


def run(args) -> CommandResult:
    from core.fixtures.base import read_base_transform
    from core.fixtures.description import read_fixture_description
    from core.fixtures.file import fixture_pose_dict, write_fixture_pose
    from core.fixtures.pairs import fixture_image_loaders, fixture_pair_files
    from core.fixtures.run import locate_fixture
    from core.task import Monitor

    check_output(args.out, "fixture pose")
    check_output(args.urdf, "URDF")
    description = read_fixture_description(args.fixture)
    base = read_base_transform(args.calibrated)
    files = fixture_pair_files(args.pairs, description.names)
    locator, _ = setup_locator(args)
    pairs = fixture_image_loaders(files, locator.rect.image_size)
    progress = ProgressLine("locate-fixture")
    try:
        result = locate_fixture(pairs, locator, base, description, progress=Monitor(progress))
    finally:
        progress.close()
    frame = result.frame
    sources = {"calibration": str(args.calibrated), "robot": base.robot, "fixture_description": str(args.fixture),
               "stereo": str(args.stereo), "marker": str(args.marker),
               "images": [{"point": n, "left": str(a), "right": str(b)} for n, (a, b) in zip(description.names, files)]}
    write_fixture_pose(args.out, frame, name=description.name, sources=sources, urdf=args.urdf)
    x, y, z = frame.position
    r, p, yaw = frame.rpy_deg
    sp, sr = frame.sigma_position_mm, frame.sigma_rotation_deg
    text = (f"Fixture '{description.name}' in the robot base frame: position {x:.3f} {y:.3f} {z:.3f} mm "
            f"(σ {sp[0]:.3f} {sp[1]:.3f} {sp[2]:.3f}), rpy {r:.3f} {p:.3f} {yaw:.3f}° "
            f"(σ {sr[0]:.4f} {sr[1]:.4f} {sr[2]:.4f}); {frame.method}, RMS residual {frame.rms_mm:.3f} mm over "
            f"{len(frame.names)} points. Wrote {args.out}" + (f" and {args.urdf}." if args.urdf else "."))
    return CommandResult(text=text, data=fixture_pose_dict(frame, name=description.name, sources=sources))
