"""`robocal identify`: kinematic identification of the robot model from measured points."""
from __future__ import annotations

import math

from app.commands import CommandResult, check_output
from app.commands import options

HELP = "Kinematic identification: DH parameters, base pose and target offsets from measurements"


INPUTS = ("robot", "measurements")      # checked against OUTPUTS before the run (app/commands/paths.py)
OUTPUTS = ("out",)


def add_arguments(parser) -> None:
    parser.add_argument("--robot", required=True, metavar="R.json", help="nominal robot model file")
    parser.add_argument("--measurements", required=True, metavar="M.csv", help="measurements file")
    parser.add_argument("--out", required=True, metavar="calibrated.json",
                        help="calibrated robot model to write (only written when identification succeeds)")
    group = parser.add_mutually_exclusive_group()
    group.add_argument("--holdout", type=options.fraction, metavar="FRACTION",
                       help="hold out this fraction of the poses for validation (e.g. 0.25); "
                            "the model is fitted on the others")
    group.add_argument("--kfold", type=options.folds, metavar="K",
                       help="K-fold cross validation (the model is fitted on all poses)")
    parser.add_argument("--fix", default="", metavar="NAMES",
                        help="comma-separated parameters to keep at their nominal value, e.g. J2.a,base.rz,marker.x")
    parser.add_argument("--huber", type=options.huber_k, metavar="K",
                        help="robust (Huber) fit: down-weight points beyond K robust standard deviations (e.g. 3)")
    parser.add_argument("--seed", type=options.seed, default=0, help="seed of the validation split (default 0)")
    parser.add_argument("--prior", type=options.prior_weight, default=False, metavar="auto|WEIGHT",
                        help="estimate the DH parameters the measurements barely determine with a prior toward "
                             "their nominal values instead of keeping them at nominal; 'auto' estimates its weights "
                             "(one for lengths, one for angles) from the measurements by empirical Bayes, "
                             "0 is the plain fit (default: no prior)")
    parser.add_argument("--orientation", action="store_true",
                        help="also fit the measured marker orientations (columns rx..srz of the measurements file) "
                             "and estimate the marker's orientation on the tool (marker.rx, marker.ry, marker.rz); "
                             "with --fix marker.rz the last joint's zero is determined even when the marker sits "
                             "on the last joint's axis")
    parser.add_argument("--compliance", choices=["off", "on", "auto"], default="off",
                        help="deflection of the shoulder and elbow under the arm's weight (a vertical articulated "
                             "arm): 'on' estimates six terms that follow the gravity torque (sin/cos of q2 and of "
                             "q2+q3), 'auto' keeps them only when cross validation over the poses shows they "
                             "predict new poses better, 'off' is geometry only (default)")
    parser.add_argument("--payload", type=options.payload_kg, metavar="KG",
                        help="the mass mounted on the flange during the measurements (kg), recorded with the "
                             "calibration: deflection terms hold for this payload")


def run(args) -> CommandResult:
    from core.errors import UsageError
    from core.identification.prior import PriorOptions
    from core.identification.file import write_calibrated_model
    from core.identification.solver import identify
    from core.measurement.file import read_measurements
    from core.provenance import forget_inputs
    from core.robot.file import read_robot

    if args.holdout is not None and not 0.0 < args.holdout < 1.0:
        raise UsageError(f"--holdout must be between 0 and 1, got {args.holdout}")
    check_output(args.out, "--out")
    robot = read_robot(args.robot)
    meas = read_measurements(args.measurements, robot)
    fixed = [n.strip() for n in args.fix.split(",") if n.strip()]
    prior = None if args.prior is False else PriorOptions(weight=args.prior)
    result = identify(robot, meas, fixed=fixed, huber=args.huber, holdout=args.holdout, kfold=args.kfold,
                      seed=args.seed, prior=prior, orientation=args.orientation, compliance=args.compliance,
                      payload_kg=args.payload)
    write_calibrated_model(result, args.out)
    forget_inputs(args.out)          # a record of the wizard's inputs belongs to the file replaced
    data = result.summary()
    data["out"] = str(args.out)
    return CommandResult(text=_text(result, args.out), data=data)


def _fmt(v) -> str:
    return "-" if v is None or (isinstance(v, float) and not math.isfinite(v)) else f"{v:.4g}"


def _text(result, out) -> str:
    lines = [f"Identified {len(result.estimated)} parameters from {result.n_points} points in "
             f"{result.n_poses} poses ({result.n_iterations} iterations).",
             f"  RMS error: {result.before.rms_mm:.4f} mm before, {result.after.rms_mm:.4f} mm after "
             f"(max {result.after.max_mm:.4f} mm); condition number {_fmt(result.condition_number)}."]
    v = result.validation
    if v is not None:
        what = f"{v.folds}-fold cross validation" if v.method == "kfold" else \
            f"{len(v.test_poses)} held-out poses"
        lines.append(f"  Validation ({what}): RMS {v.before.rms_mm:.4f} mm before, {v.after.rms_mm:.4f} mm after "
                     f"(max {v.after.max_mm:.4f} mm).")
    o = result.orientation
    if o is not None:
        lines.append(f"  Orientation ({o.n_points} points): RMS {o.rms_before_deg:.4f} deg before, "
                     f"{o.rms_after_deg:.4f} deg after"
                     + (f"; held out {o.holdout_rms_after_deg:.4f} deg." if o.holdout_rms_after_deg is not None
                        else "."))
        if o.determined:
            lines.append("    determined only thanks to the orientation: " + ", ".join(o.determined))
    p = result.prior
    if p is not None:
        how = "given" if p.chosen_by == "given" else f"chosen by {p.chosen_by}"
        if p.weights.plain:
            lines.append(f"  Prior toward nominal: weight 0 ({how}): the plain fit.")
        else:
            lines.append(f"  Prior toward nominal: weight {p.weight_text} ({how}), i.e. ± {p.std_length_mm:.3g} "
                         f"per DH length (mm), ± {p.std_angle_deg:.3g} per angle (deg)"
                         + (" in units of the measurements' σ." if result.weighted else "."))
        if p.dominated:
            lines.append("    dominated by the prior (share the measurements determine): " + ", ".join(
                f"{n} {p.shares[n]:.0%}" for n in p.dominated))
    c = result.compliance
    if c is not None and c.mode != "off":
        lines.append(f"  Deflection under the arm's weight: {c.verdict}")
    if result.payload_kg is not None:
        lines.append(f"  Payload during calibration: {result.payload_kg:g} kg.")
    elif c is not None and c.kept:
        lines.append("  Payload during calibration: not given (--payload KG); the deflection terms hold for the "
                     "payload that was mounted.")
    if result.unidentifiable:
        lines.append("  Not estimated (kept at nominal):")
        for r in result.unidentifiable:
            lines.append(f"    {r.name}: {r.explanation}")
    lines.append("  Parameters (nominal -> identified ± std):")
    for r in result.parameters:
        if r.identifiable:
            lines.append(f"    {r.name:<12} {r.nominal:12.4f} -> {r.identified:12.4f} ± {_fmt(r.std):<8} {r.unit}")
    for w in result.warnings:
        lines.append(f"  Note: {w}.")
    lines.append(f"Wrote {out}.")
    return "\n".join(lines)
