"""Identifying a newly mounted tool (Qt-free; the Check page and `robocal identify-tool` use it):
propose the tool's few poses, measure them (on the virtual lab, or read from a measurements
file), identify the tool's offsets with the calibrated arm as prior and write the updated
calibrated robot file atomically."""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from app.jobs.check import CANDIDATES, history_path, lab_measure, weighted_sigma_mm, write_keeping_previous
from app.lab import lab_options as lab_options_of
from core.errors import RoboCalError
from core.measurement.file import Measurements, read_measurements
from core.monitoring.reidentify import write_reidentified
from core.monitoring.tool_identification import ToolIdentification, identify_tool, propose_tool_poses
from core.monitoring.uncertainty import calibration_uncertainty
from core.poses.selection import PoseSelectionResult
from core.robot.file import read_robot
from core.task import Monitor


@dataclass
class ToolUpdate:
    """A tool identified and written to `path`, with the poses it was measured at (rad / mm)."""

    identification: ToolIdentification
    path: Path
    proposed: np.ndarray


def propose(calibrated, tool: str, *, lab_options: dict | None = None, count: int | None = None, seed: int = 0,
            progress=None, cancelled=None) -> PoseSelectionResult:
    """The poses that determine `tool`'s offsets on the calibrated robot `calibrated` (a file),
    with the lab's (or cell's) cameras and marker in `lab_options`."""
    model = read_robot(calibrated)
    opts = {k: v for k, v in (lab_options or {}).items() if k != "robot"}
    return propose_tool_poses(model, tool, count=count, candidates=CANDIDATES, seed=seed, progress=progress,
                              cancelled=cancelled, **opts)


def identify_from_file(calibrated, tool: str, measurements, out, *, sigma_mm: float | None = None,
                       progress=None, cancelled=None) -> ToolUpdate:
    """Identify `tool` from a measurements file of its poses and write `out`."""
    model = read_robot(calibrated)
    return identify_from_measurements(calibrated, tool, read_measurements(measurements, model), out,
                                      sigma_mm=sigma_mm, progress=progress, cancelled=cancelled)


def identify_from_measurements(calibrated, tool: str, meas: Measurements, out, *, sigma_mm: float | None = None,
                               progress=None, cancelled=None) -> ToolUpdate:
    """Identify `tool` from measured points of its targets (a file, captured pairs or the
    connected cell: app.jobs.check_sources) and write `out` atomically."""
    model = read_robot(calibrated)
    unc = calibration_uncertainty(model, source=calibrated, sigma_mm=sigma_mm)
    result = identify_tool(model, unc, tool, meas, previous=str(calibrated), progress=progress, cancelled=cancelled)
    path = write_reidentified(result.reidentification, out)
    return ToolUpdate(result, Path(path), meas.with_robot(model).Q if meas.Q is None else meas.Q)


def identify_on_lab(calibrated, tool: str, lab, out=None, *, change: str | None = None, images=None,
                    sigma_mm: float | None = None, count: int | None = None, seed: int = 0, progress=None,
                    cancelled=None) -> ToolUpdate:
    """Mount `tool` on the virtual lab, measure its proposed poses (ideal noise: the calibration's
    σ; with `images`: through rendered images), identify it and write `out` (None: replace
    `calibrated`, the previous file kept in history/). `change` (a lab change) happens first."""
    monitor = Monitor(progress, cancelled)
    model = read_robot(calibrated)
    sigma_mm = weighted_sigma_mm(calibrated) if sigma_mm is None else sigma_mm
    unc = calibration_uncertainty(model, source=calibrated, sigma_mm=sigma_mm)
    proposal = propose(calibrated, tool, lab_options=lab_options_of(lab), count=count, seed=seed,
                       progress=monitor.sub(0.0, 0.5), cancelled=cancelled)
    Q, poses, targets, xyz = [], [], [], []
    for i, target in enumerate(model.tool_targets(tool)):     # each target its own noise
        measure = lab_measure(lab, change, sigma_mm=unc.sigma_mm, seed=seed + 1000 * i, images=images, target=target)
        for k, q in enumerate(proposal.Q):
            monitor.step(0.5 + 0.4 * k / len(proposal.Q), f"measuring {target} at pose {k + 1} of {len(proposal.Q)}")
            p = measure(q)
            if p is not None:
                Q.append(q)
                poses.append(k)
                targets.append(target)
                xyz.append(p)
    if not Q:
        raise RoboCalError(f"the marker of tool '{tool}' was found at none of the {len(proposal.Q)} proposed poses",
                           hint="Check that the tool is mounted and the marker faces the cameras.")
    Q = np.array(Q)
    meas = Measurements(pose=np.array(poses), target=targets, q_file=model.q_to_file(Q), xyz=np.array(xyz), Q=Q)
    target = Path(calibrated if out is None else out)
    kept = history_path(target) if out is None and target.is_file() else None
    result = identify_tool(model, unc, tool, meas, previous=str(kept or calibrated), progress=monitor.sub(0.9, 1.0),
                           cancelled=cancelled)
    path = write_keeping_previous(result.reidentification, target, kept)
    return ToolUpdate(result, Path(path), proposal.Q)
