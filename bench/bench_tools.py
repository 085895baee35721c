"""A second tool identified on the calibrated arm from its own few proposed poses (a tool changer).

The educational 6R arm with two tools ("gripper": marker 25 mm out; "long_gripper": 110 mm out,
15 mm aside), calibrated with the gripper from 50 ideal lab measurements (σ = 0.05 mm per axis)
for several calibration seeds; then the long gripper's offset is identified from its proposed
poses, measured with fresh noise several times. The error is against the offset the calibrated
arm sees (core.virtual_lab.tool_truth), beside the identification's own predicted σ = √trace(C).
"""
from __future__ import annotations

import copy

import numpy as np

from core.identification.solver import identify
from core.measurement.file import Measurements
from core.monitoring.tool_identification import identify_tool, propose_tool_poses
from core.monitoring.uncertainty import calibration_uncertainty
from core.robot.file import read_robot
from core.robot.model import robot_path
from core.virtual_lab.ideal_measurements import ideal_lab_measurements, ideal_measure
from core.virtual_lab.lab import VirtualLab, lab_options
from core.virtual_lab.tool_truth import equivalent_offset

SIGMA = 0.05
CALIBRATIONS = 8
TRIALS = 5


def run(report) -> None:
    robot = read_robot(robot_path("educational_6r"))
    robot.targets["long_marker"] = np.array([0.0, 15.0, 110.0])
    robot.tools = {"gripper": ["marker"], "long_gripper": ["long_marker"]}
    lab = VirtualLab.create(robot, seed=0)
    opts = lab_options(lab)
    opts.pop("robot")
    long_lab = copy.copy(lab)
    long_lab.target = "long_marker"
    errors, sigmas, poses = [], [], []
    for s in range(CALIBRATIONS):
        res = identify(lab.nominal_robot, ideal_lab_measurements(lab, 50, sigma_mm=SIGMA, seed=200 + s))
        model = res.model.copy()
        model.calibration = res.calibration_section()
        unc = calibration_uncertainty(model)
        proposal = propose_tool_poses(model, "long_gripper", candidates=600, seed=s, **opts)
        for k in range(TRIALS):
            measure = ideal_measure(long_lab, sigma_mm=SIGMA, seed=1000 * s + k)
            xyz = np.array([measure(q) for q in proposal.Q])
            meas = Measurements(pose=np.arange(len(xyz)), target=["long_marker"] * len(xyz),
                                q_file=model.q_to_file(proposal.Q), xyz=xyz, Q=proposal.Q)
            result = identify_tool(model, unc, "long_gripper", meas)
            truth = equivalent_offset(lab, result.model, "long_marker")     # in the re-identified arm's tool frame
            errors.append(float(np.linalg.norm(result.offsets["long_marker"] - truth)))
            sigmas.append(result.sigma_mm)
            poses.append(len(proposal.Q))
    errors, sigmas = np.array(errors), np.array(sigmas)
    n = len(errors)
    report.info("second tool's predicted σ (√trace C)", f"{sigmas.mean():.3f} mm", "")
    report.add("second tool's offset error, RMS", float(np.sqrt(np.mean(errors ** 2))), "<=", 0.15, "mm",
               f"{n} identifications; predicted σ {np.sqrt(np.mean(sigmas ** 2)):.3f} mm; worst {errors.max():.3f} mm")
    report.add("second tool's offset error / its predicted σ, RMS", float(np.sqrt(np.mean((errors / sigmas) ** 2))),
               "<=", 1.3, "", "1 when the predicted σ is right")
    report.add("poses to identify the second tool", float(max(poses)), "<=", 6.0, "poses",
               "proposed by observability of its 3 offsets, the arm held at its calibration")
