"""Monitoring a calibrated cell on the virtual lab: false alarms, detection, diagnosis, re-identification.

Ideal lab measurements (the true robot + Gaussian noise σ = 0.05 mm per axis, 3D σ = σ·√3), the
educational 6R arm calibrated from 50 poses; several calibrations (measurement seeds) so that the
rates include the calibration's own scatter. Checks at α = 1 % unless said.
"""
from __future__ import annotations

import math

import numpy as np

from core.identification.solver import identify
from core.monitoring.check import check_limits, run_check
from core.monitoring.check_poses import select_check_poses
from core.monitoring.diagnosis import diagnose
from core.monitoring.reidentify import propose_poses, reidentify
from core.monitoring.uncertainty import calibration_uncertainty
from core.measurement.file import Measurements
from core.identification.solver import error_stats
from core.virtual_lab.changes import apply_change
from core.virtual_lab.ideal_measurements import ideal_lab_measurements, ideal_measure
from core.virtual_lab.lab import VirtualLab, lab_options
from core.virtual_lab.synthetic import simulate_measurements

SIGMA = 0.05
CALIBRATIONS = 6
REID_DRAWS = 5      # check noise and full recalibration poses per calibration


def _calibrated(lab, seed):
    res = identify(lab.nominal_robot, ideal_lab_measurements(lab, 50, sigma_mm=SIGMA, seed=seed))
    model = res.model.copy()
    model.calibration = res.calibration_section()
    return model, calibration_uncertainty(model)


def run(report) -> None:
    lab = VirtualLab.create(seed=0)
    true = lab.true_robot
    opts = lab_options(lab)
    opts.pop("robot")
    cells = []
    for s in range(CALIBRATIONS):
        model, unc = _calibrated(lab, 100 + s)
        Q5 = select_check_poses(model, 5, candidates=600, **opts).Q
        Q8 = select_check_poses(model, 8, candidates=600, **opts).Q
        cells.append((model, unc, Q5, check_limits(model, unc, Q5, ["marker"] * 5, 0.01),
                      Q8, check_limits(model, unc, Q8, ["marker"] * 8, 0.01)))

    # false alarms: no change
    alarms = total = 0
    for s, (model, unc, Q5, L5, _, _) in enumerate(cells):
        for k in range(300):
            r = run_check(model, unc, Q5, ideal_measure(lab, sigma_mm=SIGMA, seed=10_000 * s + k), limits=L5)
            alarms += not r.within
            total += 1
    report.add("false alarms, no change, 5 check poses (α 1 %)", 100 * alarms / total, "<=", 1.5, "%",
               f"{total} checks over {CALIBRATIONS} calibrations; nominal 1 %")

    # smallest tool change detected with 95 % probability (5 check poses)
    smallest = math.inf
    for size in (0.1, 0.15, 0.2, 0.25, 0.3, 0.4, 0.5, 0.7):
        hits = n = 0
        for s, (model, unc, Q5, L5, _, _) in enumerate(cells):
            for k in range(40):
                lab.true_robot = true
                apply_change(lab, f"tool:{size}", seed=1000 * s + k)
                r = run_check(model, unc, Q5, ideal_measure(lab, sigma_mm=SIGMA, seed=7 + k), limits=L5)
                hits += not r.within
                n += 1
        lab.true_robot = true
        report.info(f"tool change {size:g} mm detected", f"{100 * hits / n:.1f} %")
        if hits / n >= 0.95:
            smallest = size
            break
    report.add("smallest tool change detected with 95 % (5 check poses)", smallest / (SIGMA * math.sqrt(3)), "<=",
               3.0, "× 3D σ", f"{smallest:g} mm; 3D σ {SIGMA * math.sqrt(3):.3f} mm")

    # diagnosis per kind (8 check poses)
    kinds = {"tool:1.5": ("tool", -1), "base:2": ("base", -1), "joint1:0.3": ("joint", 0),
             "joint2:0.3": ("joint", 1), "joint3:0.3": ("joint", 2), "joint4:0.3": ("joint", 3),
             "joint5:0.3": ("joint", 4), "link3:1": ("several", -1)}
    for spec, (kind, joint) in kinds.items():
        right = n = 0
        for s, (model, unc, _, _, Q8, L8) in enumerate(cells):
            for k in range(15):
                lab.true_robot = true
                apply_change(lab, spec, seed=1000 * s + k)
                r = run_check(model, unc, Q8, ideal_measure(lab, sigma_mm=SIGMA, seed=500 + k), limits=L8)
                n += 1
                if r.within:
                    continue
                d = diagnose(model, unc, r)
                right += d.kind == kind and (joint < 0 or d.chosen.joint == joint)
        lab.true_robot = true
        report.add(f"diagnosis right: {spec}", 100 * right / n, ">=", 95.0, "%", f"{n} trials, 8 check poses")

    # re-identification after a tool swap vs a full recalibration (held-out poses). One draw of a
    # full recalibration's held-out error scatters by ±25 % (50 random poses), and so does the
    # previous calibration each re-identification keeps: the ratio of single draws fails 1.2 even
    # for the previous calibration with the exact new tool. So both errors are pooled (RMS) over
    # every cell and several draws of the check's noise and of the full recalibration's poses.
    reid_sq, full_sq, ratios, fractions, proposed = [], [], [], [], []
    for s, (model, unc, _, _, Q8, L8) in enumerate(cells):
        lab.true_robot = true
        apply_change(lab, "tool:2", seed=s)
        held = ideal_lab_measurements(lab, 40, sigma_mm=0.0, seed=950 + s)
        for j in range(REID_DRAWS):
            r = run_check(model, unc, Q8, ideal_measure(lab, sigma_mm=SIGMA, seed=s + 1000 * j), limits=L8)
            d = diagnose(model, unc, r)
            proposal = propose_poses(model, unc, d.parameters, r.Q, candidates=600, **opts)
            new = simulate_measurements(lab.true_robot, len(proposal.Q), Q=proposal.Q, sigma_mm=SIGMA,
                                        targets=["marker"], rng=s + 1000 * j)
            Q = np.vstack([new.Q, r.Q])
            meas = Measurements(pose=np.arange(len(Q)), target=["marker"] * len(Q), q_file=model.q_to_file(Q),
                                xyz=np.vstack([new.xyz, [p.measured for p in r.points]]), Q=Q)
            re = error_stats(reidentify(model, unc, d.parameters, meas).model, held).rms_mm
            full = error_stats(identify(lab.nominal_robot, ideal_lab_measurements(
                lab, 50, sigma_mm=SIGMA, seed=900 + s + 1000 * j)).model, held).rms_mm
            reid_sq.append(re ** 2)
            full_sq.append(full ** 2)
            ratios.append(re / full)
            fractions.append(len(Q) / 50)
            proposed.append(len(proposal.Q))
    lab.true_robot = true
    report.add("re-identified tool swap: held-out error / full recalibration's",
               math.sqrt(np.mean(reid_sq) / np.mean(full_sq)), "<=", 1.2, "",
               f"RMS over {len(ratios)} trials ({CALIBRATIONS} calibrations × {REID_DRAWS}); single trials "
               f"{min(ratios):.2f}–{max(ratios):.2f}; {min(proposed)}–{max(proposed)} proposed poses + 8 check poses")
    report.add("re-identification poses / full recalibration's", 100 * max(fractions), "<=", 20.0, "%",
               "proposed + check poses, against 50; the most of any trial")
