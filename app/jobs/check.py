"""The Check step's wiring (Qt-free; the page and `robocal check` use it): read the calibrated
robot and its uncertainty, choose or read the check poses, measure them on the virtual lab, judge,
diagnose, and re-identify what changed from the proposed poses."""
from __future__ import annotations

import copy
from dataclasses import dataclass, replace
from datetime import datetime, timezone
from pathlib import Path

import numpy as np

from app.lab import apply_change, ideal_measure, image_measure, lab_options as lab_options_of
from core.files import atomic_write_bytes
from core.kinematics.jacobian import predict_points
from core.measurement.file import Measurements
from core.measurement.point import MeasuredPoint
from core.monitoring.check import CheckLimits, CheckResult, check_limits, run_check
from core.monitoring.check_poses import DEFAULT_CHECK_POSES, select_check_poses
from core.monitoring.diagnosis import Diagnosis, diagnose
from core.monitoring.reidentify import Reidentification, propose_poses, reidentify, write_reidentified
from core.monitoring.tool_identification import calibrated_targets, calibrated_tools
from core.monitoring.uncertainty import CalibrationUncertainty, calibration_uncertainty, statistics_sigma_mm
from core.errors import RoboCalError
from core.poses.file import read_poses
from core.robot.file import read_robot
from core.robot.model import RobotModel
from core.task import Monitor

CANDIDATES = 600
#: shares of the progress bar, from timing the educational 6R's 8 check poses on the virtual lab:
#: choosing the poses ~1 s, their limits ~5 s (no progress inside); a pair rendered and located
#: takes ~1 s per pose (the Marker page's verification), so a check through images about as long
#: as both; one with ideal measurements a few ms
SELECTION_SHARE = 0.2
CHECK_SHARE_IMAGES = 0.5
CHECK_SHARE_IDEAL = 0.02


@dataclass
class CheckSetup:
    """A calibrated robot ready to be checked: its uncertainty, check poses and their limits."""

    model: RobotModel
    unc: CalibrationUncertainty
    Q: np.ndarray
    limits: CheckLimits
    source: str
    target: str = "marker"
    tool: str = ""              # the tool mounted (its target is `target`)


def mounted_tool(model: RobotModel, unc: CalibrationUncertainty, tool: str | None, source,
                 target: str | None = None) -> tuple[str, str]:
    """(tool, target) a check measures: `tool` (None: the first calibrated one, or the one that
    carries `target`) and its first calibrated target, or `target` (e.g. one placed on the tool
    with its covariance, core.identification.placement). Raises RoboCalError for a tool not
    identified since the calibration, or a `target` without a covariance."""
    if target is not None:
        tool = tool or model.tool_of(target)
        if target not in calibrated_targets(model, unc, tool):
            raise RoboCalError(f"the target '{target}' of the tool '{tool}' has no calibration covariance to set "
                               "the check's limits", source=source, field="calibration.covariance",
                               hint="Place it with its uncertainty (robocal check --place), or identify the tool.")
        return tool, target
    if tool is None:
        tools = calibrated_tools(model, unc)
        if not tools:
            raise RoboCalError("no tool of this robot was calibrated", source=source, field="calibration.covariance",
                               hint="Use the calibrated robot file written by the Identification step.")
        tool = tools[0]
    targets = calibrated_targets(model, unc, tool)
    if not targets:
        raise RoboCalError(f"the tool '{tool}' has not been identified since the calibration", source=source,
                           field="calibration.tools",
                           hint="Mount it and identify it first (robocal identify-tool, or Identify tool on the "
                                "Check page).")
    return tool, targets[0]


def setup(robot_path, *, lab_options: dict | None = None, poses_path=None, count: int = DEFAULT_CHECK_POSES,
          alpha: float = 0.01, sigma_mm: float | None = None, seed: int = 0, tool: str | None = None,
          Q=None, model: RobotModel | None = None, target: str | None = None, progress=None, cancelled=None
          ) -> CheckSetup:
    """Read the calibrated robot (or take `model`, read from it and changed, e.g. with targets
    placed), take the check poses Q (rad / mm), or from `poses_path`, or
    choose `count` of them (with the lab's or cell's cameras and marker in `lab_options`) for the
    mounted `tool` (None: the first calibrated one) and its `target` (None: its first calibrated
    one; see mounted_tool), and compute their limits."""
    monitor = Monitor(progress, cancelled)
    model = read_robot(robot_path) if model is None else model
    unc = calibration_uncertainty(model, source=robot_path, sigma_mm=sigma_mm)
    tool, target = mounted_tool(model, unc, tool, robot_path, target)
    if Q is not None:
        Q = np.atleast_2d(np.asarray(Q, dtype=float))
    elif poses_path is not None:
        Q = read_poses(poses_path, model).Q
    else:
        opts = {k: v for k, v in (lab_options or {}).items() if k != "robot"}
        opts["target"] = target
        Q = select_check_poses(model, count, candidates=CANDIDATES, seed=seed,
                               progress=monitor.sub(0.0, SELECTION_SHARE), cancelled=cancelled, **opts).Q
    monitor.step(SELECTION_SHARE, "limits of the check poses")
    limits = check_limits(model, unc, Q, [target] * len(Q), alpha)
    monitor.step(1.0, "ready")
    return CheckSetup(model, unc, Q, limits, str(robot_path), target, tool)


def check(cell: CheckSetup, measure, *, log=None, progress=None, cancelled=None
          ) -> tuple[CheckResult, Diagnosis | None]:
    """One check appended to `log`; the diagnosis when it left its limits."""
    result = run_check(cell.model, cell.unc, cell.Q, measure, target=cell.target, tool=cell.tool, log=log,
                       alpha=cell.limits.alpha, limits=cell.limits, progress=progress, cancelled=cancelled)
    diagnosis = None
    if result.points and not result.cancelled and not result.within:
        diagnosis = diagnose(cell.model, cell.unc, result)
    return result, diagnosis


@dataclass
class Update:
    """A re-identification written to `path`, with the check of the updated model."""

    reidentification: Reidentification
    path: Path
    proposed: np.ndarray
    after: CheckResult
    cell: CheckSetup            # the updated robot, ready for the next check


def reidentify_from_proposed(cell: CheckSetup, result: CheckResult, diagnosis: Diagnosis, measure, out, *,
                             lab_options: dict | None = None, log=None, seed: int = 0, archive: bool = False,
                             progress=None, cancelled=None) -> Update:
    """Propose the few poses that, with the check's points (measured after the change), determine
    what changed, measure them, re-identify from them and the check's points with the calibration
    as prior, check the updated model at the check poses, and only when all that succeeded (that
    check completed, not stopped or cut short by a fault) and its overall RMS is within its
    limit: keep the file at `out` in history/ (`archive`) and write `out` atomically. A failure, or an updated model still out of limits as a whole
    (RoboCalError advising a full calibration), leaves no file behind; one point beyond its own
    limit alone does not refuse it (the next check shows it). A connected cell's `measure`
    (app.jobs.cell_measure.CellMeasure: it has `follow`) moves on to the next proposed pose, and
    then to the next check pose, while the marker is located, as during the check."""
    monitor = Monitor(progress, cancelled)
    opts = {k: v for k, v in (lab_options or {}).items() if k != "robot"}
    opts["target"] = cell.target
    proposal = propose_poses(cell.model, cell.unc, diagnosis.parameters, result.Q, candidates=CANDIDATES,
                             seed=seed, measured_scale=diagnosis.chosen.noise_scale,
                             new_per_parameter=with_own_covariance(result), progress=monitor.sub(0.0, 0.3),
                             cancelled=cancelled, **opts)
    Qs, xyz = [], []
    follow = getattr(measure, "follow", None)       # a connected cell moves on while the marker is located
    if follow is not None:
        follow(proposal.Q)
    for k, q in enumerate(proposal.Q):
        monitor.step(0.3 + 0.3 * k / len(proposal.Q), f"measuring proposed pose {k + 1} of {len(proposal.Q)}")
        p = measure(q)
        if p is not None:
            Qs.append(q)
            xyz.append(p)
    Qs += [p.Q for p in result.points]
    xyz += [p.measured for p in result.points]
    Q = np.array(Qs)
    meas = Measurements(pose=np.arange(len(Q)), target=[cell.target] * len(Q), q_file=cell.model.q_to_file(Q),
                        xyz=np.array(xyz), Q=Q)
    out = Path(out)
    kept = history_path(out) if archive and out.is_file() else None
    scale = [1.0] * (len(Q) - len(result.points)) + [diagnosis.chosen.noise_scale] * len(result.points)
    re = reidentify(cell.model, cell.unc, diagnosis.parameters, meas, noise_scale=scale, reason=diagnosis.text,
                    previous=str(kept) if kept is not None else cell.source, progress=monitor.sub(0.6, 0.7),
                    cancelled=cancelled)
    unc = updated_uncertainty(re, cell.unc, out)
    updated = replace(cell, model=re.model, unc=unc, source=str(out),
                      limits=check_limits(re.model, unc, cell.Q, [cell.target] * len(cell.Q), cell.limits.alpha))
    if follow is not None:
        follow(cell.Q)
    after, _ = check(updated, measure, log=log, progress=monitor.sub(0.7, 1.0), cancelled=cancelled)
    if after.cancelled:
        raise RoboCalError(f"the check of the updated robot stopped after {len(after.points)} of {len(cell.Q)} "
                           f"poses, so the re-identification of {', '.join(re.changed)} is not confirmed; {out.name} "
                           "was not changed", hint="Run Re-identify again once the robot can complete the check.")
    if not after.points:
        raise RoboCalError(f"the marker was found at none of the {len(cell.Q)} check poses of the updated robot, so "
                           f"the re-identification of {', '.join(re.changed)} is not confirmed; {out.name} was not "
                           "changed", hint="Check that the cameras see the marker, then run Re-identify again.")
    if after.rms_mm > after.rms_limit_mm:     # as a whole, not one point
        raise RoboCalError(f"after re-identifying {', '.join(re.changed)} the check is still out of limits "
                           f"({after.rms_mm:.3f} mm RMS, limit {after.rms_limit_mm:.3f} mm); {out.name} was not "
                           "changed", hint="The change is not only what the diagnosis found: run a full calibration.")
    path = write_keeping_previous(re, out, kept)
    return Update(re, Path(path), proposal.Q, after, updated)


def with_own_covariance(result: CheckResult) -> bool:
    """Whether the check's points were measured with their own covariance: located in images (the
    stereo calibration's errors repeat at a pose), or from a file with σ columns (an instrument's
    errors at a pose are taken to repeat the same way). The re-identification then proposes at
    least one new pose per changed parameter (core.monitoring.reidentify)."""
    return any(c is not None for c in result.covariances)


def write_keeping_previous(re: Reidentification, out: Path, kept: Path | None) -> Path:
    """Copy `out` to `kept` (when given), then write the re-identified robot to `out`; when the
    write fails, the copy is removed again."""
    if kept is not None:
        atomic_write_bytes(kept, out.read_bytes())
    try:
        return write_reidentified(re, out)
    except BaseException:
        if kept is not None:
            kept.unlink(missing_ok=True)
        raise


def lab_measure(lab, change: str | None, *, sigma_mm: float, seed: int = 0, images=None, target: str | None = None):
    """`measure(q)` on the virtual lab as if `change` (tool:MM, base:MM, jointK:DEG, linkK:MM,
    mount:TOOL or None) had happened, with the marker `target` (the mounted tool's; None: the
    lab's). With `images` = (trained marker, stereo rectification): the lab renders the pair and
    the marker is located in it, as the calibration measured; without: the lab's true marker
    position plus noise `sigma_mm` (mm per axis). The change is made on a copy, so the lab the
    other steps share keeps its robot and tool."""
    if target and target not in lab.true_robot.targets:
        raise RoboCalError(f"the virtual lab's robot has no target '{target}'",
                           hint="Build the lab from the robot file that defines the tool (its \"tools\"): the "
                                "project's robot, or --lab-robot.")
    if change or (target and target != lab.target):
        lab = copy.copy(lab)
        lab.target = target or lab.target
    if change:
        apply_change(lab, change)
    if images is not None:
        from core.marker.location import MarkerLocator
        return image_measure(lab, MarkerLocator(*images).locate, seed=seed)
    return ideal_measure(lab, sigma_mm=sigma_mm, seed=seed)


def check_on_lab(cell: CheckSetup, lab, change: str | None, *, images=None, log=None, seed: int = 0,
                 progress=None, cancelled=None) -> tuple[CheckResult, Diagnosis | None]:
    """One check on the virtual lab (see `lab_measure`; ideal noise: the calibration's own σ)."""
    measure = lab_measure(lab, change, sigma_mm=cell.unc.sigma_mm, seed=seed, images=images, target=cell.target)
    return check(cell, measure, log=log, progress=progress, cancelled=cancelled)


def history_path(path) -> Path:
    """history/<name>-<UTC time>.json beside the calibrated robot file `path`: where a
    re-identification keeps the calibration it replaces (nothing is written here)."""
    path = Path(path)
    stamp = datetime.now(timezone.utc).strftime("%Y%m%dT%H%M%S.%fZ")     # two in one second stay apart
    return path.parent / "history" / f"{path.stem}-{stamp}.json"


def reidentify_on_lab(cell: CheckSetup, result: CheckResult, diagnosis: Diagnosis, lab, change: str | None,
                      calibrated, *, images=None, lab_options: dict | None = None, log=None, seed: int = 0,
                      progress=None, cancelled=None) -> Update:
    """Re-identify what `diagnosis` found from the proposed poses measured on the virtual lab and
    the check's points, and replace `calibrated` (atomically, only on success; the previous file
    is then kept in history/)."""
    measure = lab_measure(lab, change, sigma_mm=cell.unc.sigma_mm, seed=seed, images=images,
                         target=cell.target)
    return reidentify_from_proposed(cell, result, diagnosis, measure, calibrated, lab_options=lab_options, log=log,
                                    seed=seed, archive=True, progress=progress, cancelled=cancelled)


def weighted_sigma_mm(path) -> float | None:
    """The measurement noise (mm per axis) of a calibration that weighted its points by their own
    σ (core.monitoring.uncertainty.statistics_sigma_mm); None for an unweighted calibration (its
    σ̂ is in mm and is used as it is). Every check reads it itself now; kept for the callers that
    pass it on."""
    stats = (read_robot(path).calibration or {}).get("statistics") or {}
    if not isinstance(stats, dict) or stats.get("sigma_hat_unit", "mm") == "mm":
        return None
    try:
        return statistics_sigma_mm(stats, path)
    except RoboCalError:
        return None


def check_share(images) -> float:
    """The check's share of a run that first chooses its poses: measuring through rendered images
    takes about as long as choosing the poses and their limits; ideal measurements take no time."""
    return CHECK_SHARE_IMAGES if images is not None else CHECK_SHARE_IDEAL


def check_project(calibrated, lab, *, cell: CheckSetup | None = None, count: int = DEFAULT_CHECK_POSES,
                  change: str | None = None, images=None, log=None, seed: int = 0, tool: str | None = None,
                  progress=None, cancelled=None) -> tuple[CheckSetup, CheckResult, Diagnosis | None]:
    """The Check page's run: choose the check poses of `calibrated` for the mounted `tool` on the
    lab unless `cell` is given, then one check (appended to `log`) and its diagnosis."""
    monitor = Monitor(progress, cancelled)
    share = 1.0 if cell is not None else check_share(images)      # of the whole run, for the check itself
    if cell is None:
        cell = setup(calibrated, lab_options=lab_options_of(lab), count=count, sigma_mm=weighted_sigma_mm(calibrated),
                     tool=tool, progress=monitor.sub(0.0, 1.0 - share), cancelled=cancelled)
    result, diagnosis = check_on_lab(cell, lab, change, images=images, log=log, seed=seed,
                                     progress=monitor.sub(1.0 - share, 1.0), cancelled=cancelled)
    return cell, result, diagnosis


def propose_reidentification(cell: CheckSetup, result: CheckResult, diagnosis: Diagnosis, *,
                             options: dict | None = None, seed: int = 0, progress=None, cancelled=None):
    """The few poses (core.monitoring.reidentify.Proposal) that, with the check's points, determine
    what `diagnosis` found; `options`: the cell's cameras and marker (core.poses.candidates)."""
    opts = {k: v for k, v in (options or {}).items() if k not in ("robot", "target")}
    return propose_poses(cell.model, cell.unc, diagnosis.parameters, result.Q, target=cell.target,
                         candidates=CANDIDATES, seed=seed, measured_scale=diagnosis.chosen.noise_scale,
                         new_per_parameter=with_own_covariance(result), progress=progress, cancelled=cancelled,
                         **opts)


def change_parameters(model: RobotModel, target: str, kind: str) -> list:
    """The parameters a change of `kind` (tool, base or joint<k>, k from 1) moves, for the check's
    `target`. RoboCalError for another kind."""
    from core.monitoring.diagnosis import JOINT, candidate_sets

    for k, _, params, joint in candidate_sets(model, target):
        name = f"{JOINT}{joint + 1}" if k == JOINT else k
        if name == kind and k in ("tool", "base", JOINT):
            return list(params)
    joints = ", ".join(f"joint{i + 1}" for i in range(model.dof))
    raise RoboCalError(f"unknown change '{kind}'", field="--change",
                       hint=f"Give the change the check's diagnosis named: tool, base or one of {joints}.")


@dataclass
class LoggedCheckPoints:
    """The points of the last check in a log (the one the re-identification follows), as
    Measurements of its target, with its tool and run name, and each point's own covariance
    ((3, 3) mm² or None) as logged."""

    run: str
    target: str
    tool: str
    measurements: Measurements
    covariances: list

    def points(self) -> list[MeasuredPoint]:
        """The logged points, each with its own covariance, in the check's order."""
        return [MeasuredPoint(p, c) for p, c in zip(self.measurements.xyz, self.covariances)]


def last_check(log, model: RobotModel) -> LoggedCheckPoints:
    """The last check in the check log `log` that has points. RoboCalError naming the log when none."""
    from core.monitoring.log import read_check_log

    checks = [c for c in read_check_log(log).checks if c.points]
    if not checks:
        raise RoboCalError("the check log holds no checked point", source=log,
                           hint="Run robocal check with this log first.")
    last = checks[-1]
    if len(last.points[0].q_file) != model.dof:
        raise RoboCalError(f"the log's checks have {len(last.points[0].q_file)} joints, the robot {model.dof}",
                           source=log, field="header", hint="Give the check log of this robot.")
    q_file = np.array([p.q_file for p in last.points])
    Q = np.atleast_2d(model.q_from_file(q_file)).reshape(len(q_file), model.dof)
    meas = Measurements(pose=np.array([p.pose for p in last.points]), target=[p.target for p in last.points],
                        q_file=q_file, xyz=np.array([p.measured for p in last.points]), Q=Q, source=str(log))
    return LoggedCheckPoints(last.run, last.points[0].target, last.tool, meas, [p.covariance for p in last.points])


@dataclass
class FileUpdate:
    """A re-identification from measured points: the result, the check of the updated robot at the
    check's points, and the file written (None when the check after it was out of limits)."""

    reidentification: Reidentification
    after: CheckResult
    path: Path | None
    n_new: int


def payload_comparison(declared_kg: float | None, model: RobotModel) -> tuple[str | None, dict | None]:
    """One line comparing the payload mounted now (`declared_kg`, None: not said) with the one the
    calibration recorded (`calibration.payload_kg`), None when nothing is worth saying, and its
    JSON. The deflection terms of a calibration hold for its own payload."""
    if declared_kg is None:
        return None, None
    recorded = (model.calibration or {}).get("payload_kg")
    terms = model.compliance is not None and not model.compliance.is_zero
    data = {"declared_kg": declared_kg, "calibration_kg": recorded,
            "differs": recorded is not None and abs(float(recorded) - declared_kg) > 1e-9, "deflection_terms": terms}
    if recorded is None:
        return (f"Payload: {declared_kg:g} kg declared; the calibration did not record the payload it was measured "
                "with, so it cannot be compared.", data)
    if not data["differs"]:
        return None, data
    why = (f"its deflection terms hold for {float(recorded):g} kg (a heavier tool bends the arm more)" if terms
           else "the arm bends more under a heavier tool")
    return f"Payload: {declared_kg:g} kg declared, {float(recorded):g} kg during calibration: {why}.", data


#: a new point this far (mm) from where the calibrated robot puts the marker is no small change
GROSS_CHANGE_MM = 50.0


def _refuse_gross_points(cell: CheckSetup, new: Measurements) -> None:
    """A re-identification repairs small changes (a few mm, a fraction of a degree): a new point
    tens of millimetres from the calibrated prediction is a wrong value (units, columns, a pose
    mixed up) or a robot that changed beyond repair; refuse it, naming the file and pose."""
    off = np.linalg.norm(new.xyz - predict_points(cell.model, new.Q, [cell.target] * len(new.Q)), axis=1)
    worst = int(np.argmax(off)) if len(off) else 0
    if len(off) and off[worst] > GROSS_CHANGE_MM:
        raise RoboCalError(f"the new point of pose {int(new.pose[worst])} is {off[worst]:.0f} mm from where the "
                           f"calibrated robot puts the marker; a change re-identification repairs moves it a few mm",
                           source=new.source or None, field=f"pose {int(new.pose[worst])}",
                           hint="Check that pose's joint values and position (units, column order); if the robot "
                                "really changed this much, calibrate it again.")


def updated_uncertainty(re: Reidentification, previous: CalibrationUncertainty, out) -> CalibrationUncertainty:
    """The re-identified model's uncertainty, from the re-identification's own parameters and
    covariance (not read back from the model: a fit far off may change the model's parametrisation)."""
    return replace(previous, parameters=list(re.parameters), covariance=re.covariance, source=str(out))


def reidentify_measured(robot_path, log, kind: str, new: Measurements, out, *, alpha: float = 0.01,
                        progress=None, cancelled=None) -> FileUpdate:
    """Re-identify the change `kind` (tool, base, joint<k>) from the last check in `log` plus the
    `new` points (measured after the change, e.g. at the proposed poses), the calibration in
    `robot_path` as prior; check the updated robot at the check's points (appended to `log`), and
    only when that check is within limits write `out` (a file there before is kept in history/)."""
    monitor = Monitor(progress, cancelled)
    logged = last_check(log, read_robot(robot_path))
    cell = setup(robot_path, Q=logged.measurements.Q, alpha=alpha, tool=logged.tool or None,
                 progress=monitor.sub(0.0, 0.1), cancelled=cancelled)
    if logged.target != cell.target:
        raise RoboCalError(f"the last check measured target '{logged.target}', the calibration's tool '{cell.tool}' "
                           f"carries '{cell.target}'", source=log, field="target",
                           hint="Give the calibrated robot file the check was made with.")
    params = change_parameters(cell.model, cell.target, kind)
    other = sorted(set(new.target) - {cell.target})
    if other:
        raise RoboCalError(f"the new points are of target(s) {', '.join(other)}, the check's of '{cell.target}'",
                           source=new.source or None, field="target", hint="Measure the same tool's marker.")
    new = new.with_robot(cell.model) if new.Q is None else new
    _refuse_gross_points(cell, new)
    Q = np.vstack([new.Q, logged.measurements.Q])
    meas = Measurements(pose=np.arange(len(Q)), target=[cell.target] * len(Q),
                        q_file=np.atleast_2d(cell.model.q_to_file(Q)).reshape(len(Q), cell.model.dof),
                        xyz=np.vstack([new.xyz, logged.measurements.xyz]), Q=Q)
    out = Path(out)
    kept = history_path(out) if out.is_file() else None
    reason = f"{kind} changed (check {logged.run}), re-identified from {len(new.Q)} new poses and the check"
    try:
        re = reidentify(cell.model, cell.unc, params, meas, reason=reason, previous=str(robot_path),
                        alpha=alpha, progress=monitor.sub(0.1, 0.8), cancelled=cancelled)
    except RoboCalError as exc:            # the new points cannot be fitted: name the file they came from
        if exc.source is not None or not new.source:
            raise
        raise RoboCalError(exc.problem, source=new.source, field=exc.field,
                           hint=f"Look at these new points first; {exc.hint or ''}".rstrip("; ")) from None
    unc = updated_uncertainty(re, cell.unc, out)
    updated = replace(cell, model=re.model, unc=unc, source=str(out),
                      limits=check_limits(re.model, unc, cell.Q, [cell.target] * len(cell.Q), alpha))
    points = iter(logged.points())
    after = run_check(updated.model, updated.unc, updated.Q, lambda q: next(points), target=cell.target,
                      tool=cell.tool, pose_ids=logged.measurements.pose, log=log, alpha=alpha, limits=updated.limits,
                      progress=monitor.sub(0.8, 1.0), cancelled=cancelled)
    path = write_keeping_previous(re, out, kept) if after.within else None
    return FileUpdate(re, after, None if path is None else Path(path), len(new.Q))
