"""`robocal sim-robot`: a robot controller simulator on a pseudo-terminal."""
from __future__ import annotations

import sys
import time

from app.commands import CommandResult, options
from core.bounds import Bound

TIME_SCALE = options.number_in(Bound(1e-3, 100.0, "", "from a thousand times faster to a hundred times slower"))
DURATION_S = options.number_in(Bound(0.0, 1e6, "s", "up to about eleven days"))
INPUTS = ("robot",)      # checked before the run (app/commands/paths.py)

HELP = ("Simulate the virtual lab robot's controller on a pseudo-terminal (RoboCal protocol v1 or GRBL), "
        "optionally with faults")


def add_arguments(parser) -> None:
    parser.add_argument("--robot", metavar="R.json",
                        help="nominal robot model file (default: the educational 6R preset); the simulator "
                             "serves the virtual lab's true robot for it")
    parser.add_argument("--protocol", choices=("robocal", "grbl"), default="robocal",
                        help="the controller's protocol (default robocal: RoboCal serial protocol v1)")
    parser.add_argument("--faults", metavar="SPEC", default="",
                        help="faults to inject, e.g. 'drop@3,garbage@5,slow@2:1.5,fault@4,disconnect@6,short@2:1' "
                             "(KIND@MOVE[:VALUE] or KIND~PROBABILITY[:VALUE]; see docs/robot-protocol.md)")
    parser.add_argument("--seed", type=options.seed, default=0,
                        help="virtual lab seed: the same as `robocal gui --demo` gives the same robot (default 0)")
    parser.add_argument("--link", metavar="PATH",
                        help="also make PATH a link to the device, kept across simulated disconnects")
    parser.add_argument("--time-scale", type=TIME_SCALE, default=1.0,
                        help="motion time factor (default 1: realistic; 0.1: ten times faster)")
    parser.add_argument("--duration", type=DURATION_S, default=0.0,
                        help="serve for this many seconds, then exit (default 0: until Ctrl-C)")
    parser.add_argument("--cameras", metavar="DIR",
                        help="after every motion, write what the virtual lab's two cameras see of the robot to "
                             "DIR/left/frame.png and DIR/right/frame.png (a project can use the two folders as "
                             "its cameras)")
    parser.add_argument("--change", metavar="SPEC",
                        help="change the simulated robot as after a tool swap, a bump or a slip: tool:MM, base:MM, "
                             "jointK:DEG or linkK:MM (e.g. tool:1.5, joint3:0.3); the controller reports the joints "
                             "as before, only the cameras (--cameras) see the change")


def run(args) -> CommandResult:
    from core.robot.controller_sim import ControllerSim, FaultPlan
    from core.robot.file import read_robot
    from app.lab import apply_change, build_lab, parse_change
    from app.sim_cameras import SimulatedCellCameras
    from core.errors import UsageError

    plan = FaultPlan.parse(args.faults)
    if args.change and not args.cameras:
        raise UsageError("--change alters what the cameras see, and there are none",
                         hint="Add --cameras DIR: the project's cameras are then DIR/left and DIR/right.")
    robot = read_robot(args.robot) if args.robot else None
    lab = build_lab(robot, args.seed, 0.5)
    change = parse_change(args.change, lab.true_robot.dof) if args.change else None
    if change is not None:
        if change.kind == "mount":
            raise UsageError("--change mount:TOOL is not a change of the robot", hint="Use tool, base, jointK or linkK.")
        apply_change(lab, change)           # the same direction of the change as the Check step's lab
    cameras = SimulatedCellCameras(lab, args.cameras, seed=args.seed) if args.cameras else None
    sim = ControllerSim(lab.true_robot, protocol=args.protocol, faults=plan, seed=args.seed,
                        time_scale=args.time_scale, link=args.link,
                        on_rest=cameras.on_rest if cameras is not None else None)
    sim.start()
    sys.stdout.write(f"{sim.port}\n")
    sys.stdout.flush()
    sys.stderr.write(f"robocal sim-robot: serving {args.protocol} for {lab.true_robot.name} (seed {args.seed}) "
                     f"on {sim.port}" + (f"; {change.describe()}" if change is not None else "")
                     + (f"; cameras in {cameras.left} and {cameras.right}" if cameras is not None else "")
                     + "; Ctrl-C ends\n")
    try:
        end = time.monotonic() + args.duration if args.duration > 0 else None
        while end is None or time.monotonic() < end:
            time.sleep(0.1)
    except KeyboardInterrupt:
        pass
    finally:
        sim.close()
    data = {"port": sim.port, "protocol": args.protocol, "moves": sim.moves, "faults": sim.fired,
            "change": str(change) if change is not None else None,
            "camera_frames": cameras.frames if cameras is not None else 0}
    return CommandResult(text=f"Served {sim.moves} moves; faults: {', '.join(sim.fired) or 'none'}.", data=data)
