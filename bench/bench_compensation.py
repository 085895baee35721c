"""Compensation on the virtual lab: the true robot's error at the joints computed with the
calibrated model, and the speed of the inverse kinematics.

The educational 6R arm of the virtual lab (seed 0) calibrated from 50 ideal measurements
(σ 0.05 mm per axis). 100 targets located by the cameras inside the calibrated workspace: the
true robot at random poses the cameras see, each stereo pair rendered and the marker located
with the lab's trained marker through the lab's stereo rig (left camera frame). For each path
the true robot's marker error at the joints sent (against what was asked) is set beside
* the calibrated model's own error against the truth at those joints (goal ≤ 1.2 ×: the
  compensation adds nothing to the model's error), and
* the error without compensation (the nominal model's joints for the same targets; goal ≥ 50 ×
  better).
Paths: targets in the camera frame (`compensate --targets --frame camera`), a nominal joint
program (`--program`: what the nominal model meant, in the calibrated base frame), and
corrected Cartesian targets given to a controller that keeps the nominal kinematics
(`--for-controller cartesian`: the controller's own IK with the nominal model).

IK speed: a 10 000-point program (position + orientation, hints 0.05 rad from the solution),
points per second of `solve_ik` beside scipy.optimize.least_squares (method "lm", the same
residual and analytic Jacobian, one point at a time) on a 300-point subset, scaled per point.
"""
from __future__ import annotations

import time

import numpy as np
from scipy.optimize import least_squares

from core.compensation.ik import IKProblem, length_scale, solve_ik, tcp_in_tool, tcp_poses
from core.compensation.program import compensate_program, compensate_targets
from core.compensation.targets import TargetList
from core.identification.solver import identify
from core.marker.location import MarkerLocator
from core.marker.training import train_marker
from core.stereo.rectification import StereoRectification
from core.virtual_lab.ideal_measurements import ideal_lab_measurements
from core.virtual_lab.lab import VirtualLab

SIGMA = 0.05
TARGETS = 100
PROGRAM = 10_000
SUBSET = 300


def _rms(e):
    return float(np.sqrt(np.mean(np.asarray(e) ** 2)))


def _errors(report, label, got, model_err, before):
    g, m, b = _rms(got), _rms(model_err), _rms(before)
    report.info(f"{label}: true robot error RMS / max", f"{g:.4f} / {np.max(got):.4f}", "mm")
    report.add(f"{label}: true error RMS / calibrated model's own", g / m, "<=", 1.2, "×",
               f"{g:.4f} mm vs {m:.4f} mm")
    report.add(f"{label}: uncompensated RMS / compensated RMS", b / g, ">=", 50.0, "×",
               f"{b:.3f} mm (max {np.max(before):.3f}) vs {g:.4f} mm (max {np.max(got):.4f})")


def run(report) -> None:
    lab = VirtualLab.create(seed=0)
    true, nominal = lab.true_robot, lab.nominal_robot
    res = identify(nominal, ideal_lab_measurements(lab, 50, sigma_mm=SIGMA, seed=4))
    cal = res.model.copy()
    cal.calibration = res.calibration_section()
    Q_true, located = _located_targets(lab, TARGETS, np.random.default_rng(7))
    miss = np.linalg.norm(located - true.target_positions(Q_true, "marker"), axis=1)
    report.info("targets located by the cameras: error against the true marker RMS / max",
                f"{_rms(miss):.4f} / {miss.max():.4f}", "mm")
    targets = TargetList([f"p{i}" for i in range(len(located))], located)

    # targets in the camera frame
    comp = compensate_targets(cal, targets, tcp="marker", frame="camera", nominal=nominal)
    report.info("targets reached by the calibrated model", f"{int(comp.ok.sum())} of {len(comp.ok)}")
    ok = comp.ok
    Q = comp.Q[ok]
    got = np.linalg.norm(true.target_positions(Q, "marker") - located[ok], axis=1)
    own = np.linalg.norm(true.target_positions(Q, "marker") - cal.target_positions(Q, "marker"), axis=1)
    plain = solve_ik(nominal, located, tcp="marker", frame="camera", hint=comp.Q)
    before = np.linalg.norm(true.target_positions(plain.Q, "marker") - located, axis=1)[ok & plain.ok]
    _errors(report, "camera-frame targets", got, own, before)
    if comp.predicted is not None:
        inside = np.mean(got <= comp.predicted.limit_mm[ok])
        report.info("true errors within the predicted 95 % length", f"{100 * inside:.0f} %")

    # for a controller with nominal kinematics: it runs its own IK on the corrected poses
    C = comp.controller_poses()
    ctrl = solve_ik(nominal, C[:, :3, 3], tcp="marker", frame="base", hint=comp.Q)
    good = ok & ctrl.ok
    Qc = ctrl.Q[good]
    got_c = np.linalg.norm(true.target_positions(Qc, "marker") - located[good], axis=1)
    own_c = np.linalg.norm(true.target_positions(Qc, "marker") - cal.target_positions(Qc, "marker"), axis=1)
    _errors(report, "for-controller cartesian", got_c, own_c, before)

    # a nominal joint program: what the nominal model meant, in the calibrated base frame
    Q_nom = Q_true
    prog = compensate_program(cal, nominal, Q_nom, tcp="marker", orientation=False)
    ok_p = prog.ok
    meant = (cal.base @ prog.intended_base)[:, :3, 3]
    Qp = prog.Q[ok_p]
    got_p = np.linalg.norm(true.target_positions(Qp, "marker") - meant[ok_p], axis=1)
    own_p = np.linalg.norm(true.target_positions(Qp, "marker") - cal.target_positions(Qp, "marker"), axis=1)
    before_p = np.linalg.norm(true.target_positions(Q_nom, "marker") - meant, axis=1)
    report.info("program points corrected", f"{int(ok_p.sum())} of {len(ok_p)}")
    _errors(report, "nominal program", got_p, own_p, before_p[ok_p])

    _speed(report, cal)


def _located_targets(lab, n: int, rng) -> tuple[np.ndarray, np.ndarray]:
    """n poses of the true robot and the marker located there from a rendered stereo pair (left
    camera frame, mm); a pair where the marker is not found is skipped."""
    locator = MarkerLocator(train_marker(lab.render_training_image(), outer_size=lab.marker.outer_size),
                            StereoRectification.from_rig(lab.rig))
    Q, points = [], []
    while len(Q) < n:
        for q in lab.random_visible_poses(n - len(Q), rng):
            location = locator.locate(*lab.render_marker_pair(q, rng))
            if location.ok:
                Q.append(q)
                points.append(location.point)
    return np.array(Q), np.array(points)


def _speed(report, model) -> None:
    rng = np.random.default_rng(3)
    lo, hi = model.sampling_range(margin=20.0)
    Q = lo + (hi - lo) * rng.random((PROGRAM, model.dof))
    T = tcp_poses(model, Q, "marker")
    hint = Q + rng.normal(0.0, 0.05, Q.shape)
    solve_ik(model, T[:20, :3, 3], T[:20, :3, :3], frame="measurement", hint=hint[:20])      # warm up
    t0 = time.perf_counter()
    ours = solve_ik(model, T[:, :3, 3], T[:, :3, :3], frame="measurement", hint=hint)
    t_ours = time.perf_counter() - t0
    rate = PROGRAM / t_ours
    report.info(f"solve_ik, {PROGRAM} points", f"{t_ours:.2f} s, {int(ours.ok.sum())} ok", "")

    prob = IKProblem(model, tcp_in_tool(model, "marker"), T, True, length_scale(model))
    idx = rng.choice(np.flatnonzero(ours.ok), SUBSET, replace=False)
    sol = np.empty((SUBSET, model.dof))
    t0 = time.perf_counter()
    for k, i in enumerate(idx):
        one = np.array([i])
        fun = lambda q: prob.evaluate(q[None], one, jacobian=False)[0][0]
        jac = lambda q: -prob.evaluate(q[None], one)[3][0]
        sol[k] = least_squares(fun, hint[i], jac=jac, method="lm", xtol=1e-15, ftol=1e-15, gtol=1e-15).x
    t_ls = (time.perf_counter() - t0) / SUBSET
    gap = np.linalg.norm(tcp_poses(model, sol, "marker")[:, :3, 3] - tcp_poses(model, ours.Q[idx], "marker")[:, :3, 3],
                         axis=1)
    dq = np.abs(sol - ours.Q[idx]).max(axis=1)
    worst = int(np.argmax(dq))
    print(f"    joints apart: median {np.rad2deg(np.median(dq)):.1e}°, worst {np.rad2deg(dq[worst]):.2f}° at q = "
          f"{np.round(np.rad2deg(ours.Q[idx[worst]]), 1)} (ours) / "
          f"{np.round(np.rad2deg(sol[worst]), 1)} (least_squares)")
    report.add(f"IK speed, {PROGRAM}-point program: solve_ik / least_squares ({SUBSET} points, scaled)",
               rate * t_ls, ">=", 10.0, "×",
               f"{rate:.0f} points/s ({t_ours:.2f} s) vs {1 / t_ls:.0f} points/s ({1e3 * t_ls:.2f} ms per point)")
    report.add("same answers as least_squares: tool point apart, max", gap.max(), "<=", 1e-6, "mm",
               f"{np.sum(dq < 1e-6)} of {SUBSET} on the same joints (1e-6 rad); the others the same pose "
               "on the other side of a near-stretched elbow")
