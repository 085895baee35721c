"""Real robot data: ABB IRB 120 laser-tracker measurements, identified from the tracker's CSV files.

The protocol of the data's README: calibrate on 36 poses x 3 flange reflectors plus the two
test reflectors measured at q = 0, predict 40 held-out test points. RoboCal reads the files
with `import-measurements`, identifies with the reflectors absent from the robot file, and is
compared with an independent fit written here (its own DH forward kinematics, the same
parameters, scipy.optimize.least_squares) on the same split, and with the published figure.

Beyond geometry: the deflection terms (identify --compliance auto, core.robot.compliance) on the
same protocol, and the test reflectors placed relative to a calibrated reflector measured in the
same pose (core.identification.placement) instead of being fitted from their single row; the
calibrated reflectors at q = 0 come from bench/data/irb120_reflectors_at_zero.csv (the published
code's values, checked here against the data's own distances between the reflectors).
"""
from __future__ import annotations

import time
from pathlib import Path

import numpy as np
from scipy.optimize import least_squares
from scipy.spatial.transform import Rotation

from core.identification.placement import place_targets
from core.identification.prior import PriorOptions
from core.kinematics.jacobian import predict_points
from core.identification.fit import evaluate
from core.identification.solver import identify
from core.measurement.file import Measurements
from core.measurement.importer import import_measurements
from core.monitoring.uncertainty import calibration_uncertainty, norm_limit, prediction_covariance
from core.robot.file import read_robot
from core.robot.model import robot_path

DATA = Path(__file__).resolve().parents[2] / "shared" / "data" / "irb120-laser-tracker"
#: p1, p2, p3 measured at q = 0, from the published code (the file says where from, and why they
#: cannot be computed from DATA)
REFLECTORS_AT_ZERO = Path(__file__).resolve().parent / "data" / "irb120_reflectors_at_zero.csv"
PUBLISHED_MINIMAL_MM = 0.23      # the data README: the paper's minimal POE model, held-out mean

# the nominal DH of the README (θ offset, d, a, α; deg and mm), Hayati's β on joint 2
NOMINAL = np.array([[0, 290, 0, -90], [-90, 0, 270, 0], [0, 0, 70, -90],
                    [0, 302, 0, 90], [0, 0, 0, -90], [180, 72, 0, 0]], dtype=float)
# what a laser tracker on flange reflectors cannot tell apart (the base and the reflector offsets absorb it)
FIXED = {(0, 0), (0, 1), (1, 1), (5, 0), (5, 1), (5, 2), (5, 3)}


def _dh(theta, d, a, alpha, beta=0.0):
    ct, st, ca, sa = np.cos(theta), np.sin(theta), np.cos(alpha), np.sin(alpha)
    A = np.array([[ct, -st * ca, st * sa, a * ct], [st, ct * ca, -ct * sa, a * st], [0, sa, ca, d], [0, 0, 0, 1]])
    if beta:
        cb, sb = np.cos(beta), np.sin(beta)
        A = A @ np.array([[cb, 0, sb, 0], [0, 1, 0, 0], [-sb, 0, cb, 0], [0, 0, 0, 1]])
    return A


class IndependentFit:
    """Every identifiable DH value, β2, the base (rotation vector + translation) and each reflector's offset."""

    def __init__(self, targets: list[str]):
        self.targets = targets
        self.free = [(j, k) for j in range(6) for k in range(4) if (j, k) not in FIXED]

    def unpack(self, x):
        dh = NOMINAL.copy()
        dh[:, [0, 3]] = np.deg2rad(dh[:, [0, 3]])
        n = len(self.free)
        for (j, k), v in zip(self.free, x[:n]):
            dh[j, k] += v
        beta2 = x[n]
        base = np.eye(4)
        base[:3, :3] = Rotation.from_rotvec(x[n + 1:n + 4]).as_matrix()
        base[:3, 3] = x[n + 4:n + 7]
        offsets = x[n + 7:].reshape(-1, 3)
        return dh, beta2, base, offsets

    def predict(self, x, Q_deg, names):
        dh, beta2, base, offsets = self.unpack(x)
        out = np.empty((len(Q_deg), 3))
        for i, (q, name) in enumerate(zip(np.deg2rad(Q_deg), names)):
            T = base.copy()
            for j in range(6):
                T = T @ _dh(q[j] + dh[j, 0], dh[j, 1], dh[j, 2], dh[j, 3], beta2 if j == 1 else 0.0)
            out[i] = T[:3, :3] @ offsets[self.targets.index(name)] + T[:3, 3]
        return out

    def fit(self, Q_deg, names, xyz):
        x0 = np.zeros(len(self.free) + 7 + 3 * len(self.targets))
        P = self.predict(x0, Q_deg, names)                    # base first: a rigid fit of the nominal points
        Pc, Mc = P - P.mean(0), xyz - xyz.mean(0)
        U, _, Vt = np.linalg.svd(Pc.T @ Mc)
        R = (U @ np.diag([1, 1, np.sign(np.linalg.det(U @ Vt))]) @ Vt).T
        n = len(self.free)
        x0[n + 1:n + 4] = Rotation.from_matrix(R).as_rotvec()
        x0[n + 4:n + 7] = xyz.mean(0) - R @ P.mean(0)
        res = least_squares(lambda x: (self.predict(x, Q_deg, names) - xyz).ravel(), x0, method="lm",
                            x_scale="jac", xtol=1e-12, ftol=1e-12)
        return res.x


def run(report) -> None:
    if not DATA.is_dir():
        report.info(f"real IRB 120 data not found at {DATA}: skipped", "")
        return
    robot = read_robot(robot_path("abb_irb120"))
    robot.targets = {}
    cal = import_measurements([DATA / "calibration.csv", DATA / "test_points_at_zero.csv"]).measurements
    test = import_measurements([DATA / "test.csv"]).measurements
    t0 = time.perf_counter()
    result = identify(robot, cal.with_robot(robot))
    t_robocal = time.perf_counter() - t0
    ours = evaluate(result.model, test.with_robot(robot))

    fit = IndependentFit(cal.target_names)
    t0 = time.perf_counter()
    x = fit.fit(cal.q_file, cal.target, cal.xyz)
    t_scipy = time.perf_counter() - t0
    err = np.linalg.norm(fit.predict(x, test.q_file, test.target) - test.xyz, axis=1)
    independent = float(err.mean())
    report.info("calibration points / test points", f"{cal.n_points} / {test.n_points}")
    report.info("parameters estimated by RoboCal / by the independent fit",
                f"{len(result.estimated)} / {len(x)}")
    report.add("IRB 120 held-out mean error, RoboCal (reflectors not in the robot file)", ours.mean_mm, "<=",
               round(independent * 1.01, 4), "mm", "target: within 1 % of the independent fit")
    report.info("IRB 120 held-out mean error, independent scipy least_squares fit", independent, "mm")
    report.info("IRB 120 held-out mean error, published minimal POE model (data README)", PUBLISHED_MINIMAL_MM, "mm")
    t0 = time.perf_counter()
    with_prior = identify(robot, cal.with_robot(robot), prior=PriorOptions())
    t_prior = time.perf_counter() - t0
    prior_mean = evaluate(with_prior.model, test.with_robot(robot)).mean_mm
    p = with_prior.prior
    report.add("IRB 120 held-out mean error, RoboCal with the prior toward nominal (weights by empirical Bayes)",
               prior_mean, "<=", min(ours.mean_mm, independent), "mm",
               f"target: no worse than without or the independent fit; measured 0.3153 (0.978 x); weights "
               f"{p.weight_text}, dominated: {', '.join(p.dominated) or 'none'}")
    for weight in (1e-4, 1e-3, 1e-2):
        fixed = identify(robot, cal.with_robot(robot), prior=PriorOptions(weight=weight)).model
        report.info(f"IRB 120 held-out mean error, prior of fixed weight {weight:g}",
                    evaluate(fixed, test.with_robot(robot)).mean_mm, "mm")
    report.info("IRB 120 held-out max error, RoboCal", ours.max_mm, "mm")
    # target about 2x the measured 0.034: scipy differentiates the model numerically, RoboCal analytically
    report.add("identification time, RoboCal / scipy least_squares on the same problem", t_robocal / t_scipy, "<",
               0.07, "ratio", f"RoboCal {t_robocal * 1000:.0f} ms, scipy {t_scipy * 1000:.0f} ms")
    # the prior's weights take two or three fits and their evidence: measured 0.114 (the plain fit 0.049 in that run)
    report.add("identification time with the prior (weights estimated), RoboCal / scipy least_squares", t_prior / t_scipy,
               "<", 0.25, "ratio", f"RoboCal {t_prior * 1000:.0f} ms")
    _deflection_and_placement(report, robot, cal, test, ours, t_robocal)


def _reflectors_at_zero() -> dict[str, np.ndarray]:
    """p1, p2, p3 at q = 0 (mm, tracker frame) from REFLECTORS_AT_ZERO."""
    zero = import_measurements([REFLECTORS_AT_ZERO]).measurements
    assert not np.any(zero.q_file), f"{REFLECTORS_AT_ZERO}: rows not at q = 0"
    return dict(zip(zero.target, zero.xyz))


def _reflector_distances(report, cal: Measurements) -> None:
    """The distances between p1, p2, p3 at q = 0 (REFLECTORS_AT_ZERO) against the same distances in
    each calibration pose of the data: they are fixed on the flange, so the file's rows must agree
    within the tracker's spread."""
    zero = _reflectors_at_zero()
    worst, words = 0.0, []
    for a, b in (("p1", "p2"), ("p1", "p3"), ("p2", "p3")):
        d = np.array([np.linalg.norm(cal.xyz[(cal.pose == p) & (np.array(cal.target) == a)][0]
                                     - cal.xyz[(cal.pose == p) & (np.array(cal.target) == b)][0])
                      for p in cal.pose_ids])
        at_zero = float(np.linalg.norm(zero[a] - zero[b]))
        z = (at_zero - d.mean()) / d.std(ddof=1)
        worst = max(worst, abs(z))
        words.append(f"{a}–{b} {at_zero:.3f} at q = 0, {d.mean():.3f} ± {d.std(ddof=1):.3f} over the poses")
    report.add("IRB 120 reflectors at q = 0 (bench/data, the published code): their distances against the "
               "calibration poses', largest difference / the poses' spread", worst, "<=", 3.0, "σ", "; ".join(words))


def _test_reflectors_beside(reference: str) -> Measurements:
    """t1 and t2 at q = 0 (the data folder), each pose with the calibrated reflector `reference`
    measured at q = 0 (REFLECTORS_AT_ZERO)."""
    zero = import_measurements([DATA / "test_points_at_zero.csv"]).measurements
    at_zero = _reflectors_at_zero()
    pose, target, xyz = [], [], []
    for p, t, x in zip(zero.pose, zero.target, zero.xyz):
        pose += [int(p), int(p)]
        target += [t, reference]
        xyz += [x, at_zero[reference]]
    return Measurements(pose=np.array(pose), target=target, q_file=np.zeros((len(pose), 6)), xyz=np.array(xyz))


def _deflection_and_placement(report, robot, cal, test, plain, t_plain) -> None:
    """Held-out errors with the deflection terms (auto), and with the test reflectors placed
    relative to p1 (the nearest calibrated reflector) after a calibration on calibration.csv alone."""
    t0 = time.perf_counter()
    auto = identify(robot, cal.with_robot(robot), compliance="auto")
    t_auto = time.perf_counter() - t0
    stats = evaluate(auto.model, test.with_robot(robot))
    report.info("IRB 120 held-out mean / RMS / max, geometry only (--compliance off)",
                f"{plain.mean_mm:.4f} / {plain.rms_mm:.4f} / {plain.max_mm:.4f}", "mm")
    report.add("IRB 120 held-out mean error, --compliance auto", stats.mean_mm, "<=", 0.20, "mm",
               f"goal 0.20, ambitious 0.17; geometry only {plain.mean_mm:.4f} in this run "
               f"({stats.mean_mm / plain.mean_mm:.3f} x); kept: {auto.compliance.kept}")
    report.info("IRB 120 held-out RMS / max, --compliance auto", f"{stats.rms_mm:.4f} / {stats.max_mm:.4f}", "mm")
    report.info("IRB 120 --compliance auto verdict", auto.compliance.verdict)
    # auto fits both models, their weights by empirical Bayes, and 5 folds of each: measured 18 x
    report.add("identification time, --compliance auto / geometry only", t_auto / t_plain, "<", 25.0, "ratio",
               f"auto {t_auto * 1000:.0f} ms, geometry only {t_plain * 1000:.0f} ms")

    calibration_only = import_measurements([DATA / "calibration.csv"]).measurements.with_robot(robot)
    _reflector_distances(report, calibration_only)
    geometry = identify(robot, calibration_only).model
    deflection = identify(robot, calibration_only, compliance="auto").model
    once = _test_reflectors_beside("p1")
    absolute = evaluate(place_targets(geometry, once.with_robot(geometry), names=["t1", "t2"])[0],
                        test.with_robot(robot))
    relative = evaluate(place_targets(geometry, once.with_robot(geometry), references=["p1"])[0],
                        test.with_robot(robot))
    report.add("IRB 120 held-out mean error, geometry only, test reflectors placed relative to p1",
               relative.mean_mm, "<=", 0.27, "mm",
               f"placed from the model alone at q = 0: {absolute.mean_mm:.4f} in this run; the published code's "
               f"protocol 0.266 mean, 0.525 max")
    report.info("IRB 120 held-out RMS / max, geometry only, placed relative to p1",
                f"{relative.rms_mm:.4f} / {relative.max_mm:.4f}", "mm")
    for reference in ("p2", "p3"):
        other = evaluate(place_targets(geometry, _test_reflectors_beside(reference).with_robot(geometry),
                                       references=[reference])[0], test.with_robot(robot))
        report.info(f"IRB 120 held-out mean error, geometry only, placed relative to {reference}", other.mean_mm, "mm")
    both = evaluate(place_targets(deflection, once.with_robot(deflection), references=["p1"])[0],
                    test.with_robot(robot))
    report.info("IRB 120 held-out mean / RMS / max, --compliance auto and placed relative to p1",
                f"{both.mean_mm:.4f} / {both.rms_mm:.4f} / {both.max_mm:.4f}", "mm")
    _placed_limits(report, deflection, once, test)


def _placed_limits(report, model, once, test) -> None:
    """The test reflectors placed relative to p1 with their covariance propagated from the
    calibration (robocal check --place): each held-out point's error against its own limit at
    99 %, and their mean Mahalanobis distance (3 when the covariance matches the errors)."""
    placed_model, placed = place_targets(model, once.with_robot(model), references=["p1"],
                                         uncertainty=calibration_uncertainty(model))
    points = test.with_robot(placed_model)
    e = points.xyz - predict_points(placed_model, points.Q, points.target)
    S = prediction_covariance(placed_model, calibration_uncertainty(placed_model), points.Q, points.target)
    blocks = [S[3 * i:3 * i + 3, 3 * i:3 * i + 3] for i in range(len(e))]
    within = np.mean([np.linalg.norm(x) <= norm_limit(b, 0.99) for x, b in zip(e, blocks)])
    distance = float(np.mean([x @ np.linalg.solve(b, x) for x, b in zip(e, blocks)]))
    report.add("IRB 120 test points of t1, t2 placed relative to p1 (--compliance auto): within their 99 % limits "
               "from the propagated covariance", 100.0 * within, ">=", 95.0, "%",
               f"placed σ {placed[0].sigma_mm:.3f} mm per axis; mean Mahalanobis distance {distance:.2f} (3 when the "
               f"limits match the errors: below, they are wider)")
