"""Deflection terms in the virtual lab: a true ABB IRB 120 that bends under its weight, and a rigid
one measured in few poses.

* deflecting: ideal lab measurements (true robot at 60 visible poses + N(0, 0.05 mm) per axis),
  identify --compliance auto; each identified coefficient against the truth in units of its σ
  (z-score), and the held-out mean error on 30 new poses against the noise floor — the true
  robot's own mean error on the same points (measured in the same run);
* rigid: 20 poses, identify --compliance auto must decline (keep geometry only).
"""
from __future__ import annotations

import time

import numpy as np

from core.identification.fit import error_stats
from core.identification.solver import identify
from core.robot.file import read_robot
from core.robot.model import robot_path
from core.virtual_lab.ideal_measurements import ideal_lab_measurements
from core.virtual_lab.lab import VirtualLab

ROBOT = "abb_irb120"
SIGMA_MM = 0.05
DEFLECTING_TRIALS = 5
DEFLECTING_POSES = 60
RIGID_TRIALS = 20
RIGID_POSES = 20


def run(report) -> None:
    robot = read_robot(robot_path(ROBOT))
    z, ratios, kept = [], [], 0
    for seed in range(DEFLECTING_TRIALS):
        lab = VirtualLab.create(robot, seed=seed, deflection=True)
        meas = ideal_lab_measurements(lab, DEFLECTING_POSES, sigma_mm=SIGMA_MM, seed=seed)
        test = ideal_lab_measurements(lab, 30, sigma_mm=SIGMA_MM, seed=1000 + seed)
        result = identify(lab.nominal_robot, meas, compliance="auto")
        kept += result.compliance.kept
        for row in result.parameters:
            if row.group == "compliance":
                truth = np.rad2deg(lab.true_robot.compliance.coefficient(int(row.name[1:].split(".")[0]) - 1, row.kind))
                z.append((row.identified - truth) / row.std)
        ratios.append(error_stats(result.model, test).mean_mm / error_stats(lab.true_robot, test).mean_mm)
    report.info(f"deflecting lab robot ({ROBOT}, {DEFLECTING_POSES} poses, σ {SIGMA_MM} mm): trials kept by auto",
                f"{kept} / {DEFLECTING_TRIALS}")
    report.add("deflection coefficients against the truth, largest |z| over all trials", float(np.max(np.abs(z))),
               "<=", 3.0, "σ", f"{len(z)} coefficients; RMS z {float(np.sqrt(np.mean(np.square(z)))):.2f}")
    report.add("deflecting lab robot: held-out mean error / noise floor, mean over trials", float(np.mean(ratios)),
               "<=", 1.15, "ratio", f"worst trial {max(ratios):.3f}")

    declined, times = 0, []
    for seed in range(RIGID_TRIALS):
        lab = VirtualLab.create(robot, seed=100 + seed)
        meas = ideal_lab_measurements(lab, RIGID_POSES, sigma_mm=SIGMA_MM, seed=100 + seed)
        t0 = time.perf_counter()
        result = identify(lab.nominal_robot, meas, compliance="auto")
        times.append(time.perf_counter() - t0)
        declined += not result.compliance.kept
    report.add(f"rigid lab robot, {RIGID_POSES} poses: --compliance auto declines", 100.0 * declined / RIGID_TRIALS,
               ">=", 95.0, "%", f"{declined} of {RIGID_TRIALS} trials; {np.mean(times) * 1000:.0f} ms per identification")
