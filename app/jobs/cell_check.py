"""The Check step on a real cell (Qt-free; the Check page runs these on a worker): the same
check, diagnosis, re-identification and tool identification as on the virtual lab
(app.jobs.check, app.jobs.tool), with the marker measured by driving the project's robot and
capturing from its cameras (app.jobs.cell_measure.CellMeasure) and the poses chosen for the
calibrated cameras (`cell_options`)."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from app.jobs import check as job
from app.jobs import tool as tool_job
from app.jobs.cell_measure import CellMeasure
from core.errors import RoboCalError
from core.measurement.file import Measurements
from core.monitoring.tool_identification import identify_tool
from core.monitoring.uncertainty import calibration_uncertainty
from core.robot.file import read_robot
from core.task import Monitor


def setup_cell(calibrated, options: dict, *, count: int, tool: str | None = None, progress=None,
               cancelled=None) -> job.CheckSetup:
    """The check poses of `calibrated` for the mounted `tool`, chosen for the cell's cameras."""
    return job.setup(calibrated, lab_options=options, count=count, sigma_mm=job.weighted_sigma_mm(calibrated),
                     tool=tool, progress=progress, cancelled=cancelled)


def check_cell(cell: job.CheckSetup, measure: CellMeasure, *, log=None, progress=None, cancelled=None):
    """One check on the cell (appended to `log`) and its diagnosis; a robot fault or Stop ends it
    after the points measured (`measure.fault` says why)."""
    try:
        return job.check(cell, measure, log=log, progress=progress, cancelled=measure.cancelled(cancelled))
    finally:
        measure.finish()


def reidentify_cell(cell: job.CheckSetup, result, diagnosis, measure: CellMeasure, calibrated, options: dict, *,
                    log=None, progress=None, cancelled=None) -> job.Update:
    """Drive the proposed poses on the cell, re-identify what changed and check the updated robot,
    then replace `calibrated` (the previous file kept in history/). A fault or Stop while the
    proposed poses are measured writes nothing; one during the check of the updated robot ends that
    check early (`measure.fault` says why)."""
    try:
        return job.reidentify_from_proposed(cell, result, diagnosis, measure, calibrated, lab_options=options,
                                            log=log, archive=True, progress=progress,
                                            cancelled=measure.cancelled(cancelled))
    finally:
        measure.finish()


def identify_tool_cell(calibrated, tool: str, measure: CellMeasure, options: dict, *, count: int | None = None,
                       progress=None, cancelled=None) -> tool_job.ToolUpdate:
    """Drive the poses proposed for the mounted `tool`, locate its marker (the tool's first target)
    at each, identify the tool on the calibrated arm and replace `calibrated` (the previous file
    kept in history/)."""
    monitor = Monitor(progress, measure.cancelled(cancelled))
    model = read_robot(calibrated)
    unc = calibration_uncertainty(model, source=calibrated, sigma_mm=job.weighted_sigma_mm(calibrated))
    proposal = tool_job.propose(calibrated, tool, lab_options=options, count=count,
                                progress=monitor.sub(0.0, 0.4), cancelled=measure.cancelled(cancelled))
    target = model.tool_targets(tool)[0]
    Q, poses, xyz = [], [], []
    measure.follow(proposal.Q)
    try:
        for k, q in enumerate(proposal.Q):
            monitor.step(0.4 + 0.5 * k / len(proposal.Q), f"measuring the tool at pose {k + 1} of {len(proposal.Q)}")
            try:
                p = measure(q)
            except RoboCalError:
                if measure.fault is not None or measure.driver.stopped:
                    raise RoboCalError(f"the tool was not identified: {measure.fault or 'the robot was stopped'}",
                                       hint="Nothing was written. Clear the fault, Resume, and identify the tool "
                                            "again.")
                continue
            if p is not None:
                Q.append(q)
                poses.append(k)
                xyz.append(p)
    finally:
        measure.finish()
    if not Q:
        raise RoboCalError(f"the marker of tool '{tool}' was found at none of the {len(proposal.Q)} proposed poses",
                           hint="Check that the tool is mounted and the marker faces the cameras.")
    Q = np.array(Q)
    meas = Measurements(pose=np.array(poses), target=[target] * len(Q), q_file=model.q_to_file(Q),
                        xyz=np.array(xyz), Q=Q)
    path = Path(calibrated)
    kept = job.history_path(path) if path.is_file() else None
    result = identify_tool(model, unc, tool, meas, previous=str(kept or calibrated), progress=monitor.sub(0.9, 1.0),
                           cancelled=cancelled)
    written = job.write_keeping_previous(result.reidentification, path, kept)
    return tool_job.ToolUpdate(result, Path(written), proposal.Q)
