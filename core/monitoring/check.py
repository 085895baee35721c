"""A check: measure the marker at the check poses and compare it with the calibrated model.

Limits come from the calibration's own predicted uncertainty (core.monitoring.uncertainty), at
a false-alarm probability `alpha` for the whole check split by Bonferroni: half for the overall
RMS error (all points together, their correlation through the shared model included) and half
shared among the points (each point's error length against its own limit). A check is within
limits when the overall RMS and every point are. A point measured with its own covariance (a
MeasuredPoint, core.measurement.point: the marker located in a pair) gets its limit from it as
soon as it is measured, and the overall limit counts it too (see core.monitoring.uncertainty).

Each point is appended to the check log as soon as it is measured (core.monitoring.log).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from datetime import datetime, timezone
from pathlib import Path
from typing import Callable

import numpy as np

from core.errors import Cancelled, RoboCalError
from core.kinematics.jacobian import predict_points
from core.measurement.point import point_covariance
from core.monitoring.log import CheckLogWriter
from core.monitoring.uncertainty import (CalibrationUncertainty, norm_limit, parameter_covariance,
                                         with_measurement_noise)
from core.robot.driver import RobotFault
from core.robot.model import RobotModel
from core.task import Monitor

DEFAULT_ALPHA = 0.01

#: measure(q) -> the marker's position (3,) in mm in the measurement frame (a MeasuredPoint
#: when the instrument gives its covariance), or None when it was not found; q in internal units
#: (rad / mm)
MeasureFn = Callable[[np.ndarray], "np.ndarray | None"]


@dataclass
class CheckPoint:
    pose: int
    target: str
    q_file: np.ndarray
    Q: np.ndarray
    measured: np.ndarray
    predicted: np.ndarray
    limit_mm: float
    covariance: np.ndarray | None = None      # the measurement's own (3, 3) mm², when it gave one

    @property
    def error(self) -> np.ndarray:
        """measured − predicted (mm, measurement frame)."""
        return self.measured - self.predicted

    @property
    def error_mm(self) -> float:
        return float(np.linalg.norm(self.error))

    @property
    def within(self) -> bool:
        return self.error_mm <= self.limit_mm


@dataclass
class CheckResult:
    """One check: its points, overall RMS and limit, the verdict, and what could not be measured."""

    run: str
    time: str
    points: list[CheckPoint]
    rms_mm: float
    rms_limit_mm: float
    alpha: float
    sigma_mm: float
    missing: list[tuple[int, str]] = field(default_factory=list)   # (pose, reason)
    cancelled: bool = False
    log: Path | None = None
    tool: str = ""                 # the tool mounted for the check ("" when not said)

    @property
    def within(self) -> bool:
        return (not self.cancelled and bool(self.points) and self.rms_mm <= self.rms_limit_mm
                and all(p.within for p in self.points))

    @property
    def Q(self) -> np.ndarray:
        return np.array([p.Q for p in self.points])

    @property
    def targets(self) -> list[str]:
        return [p.target for p in self.points]

    @property
    def covariances(self) -> list:
        """Each point's own measurement covariance (3, 3) mm², or None."""
        return [p.covariance for p in self.points]

    @property
    def residuals(self) -> np.ndarray:
        """(3N,) measured − predicted, point by point."""
        return np.concatenate([p.error for p in self.points]) if self.points else np.zeros(0)

    def verdict(self) -> str:
        if self.cancelled:
            return f"Check stopped after {len(self.points)} poses; nothing was judged."
        if not self.points:
            return "No pose could be measured; nothing was judged."
        out = [p for p in self.points if not p.within]
        state = "within limits" if self.within else "OUT OF LIMITS"
        text = (f"Check {state}: RMS error {self.rms_mm:.3f} mm (limit {self.rms_limit_mm:.3f} mm) over "
                f"{len(self.points)} poses")
        if out:
            text += "; outside their limits: " + ", ".join(f"pose {p.pose} ({p.error_mm:.2f} mm > "
                                                          f"{p.limit_mm:.2f} mm)" for p in out)
        if self.missing:
            text += f"; {len(self.missing)} pose(s) not measured"
        return text + "."

    def summary(self) -> dict:
        return {"run": self.run, "time": self.time, "tool": self.tool, "within": self.within, "rms_mm": self.rms_mm,
                "rms_limit_mm": self.rms_limit_mm, "alpha": self.alpha, "sigma_mm": self.sigma_mm,
                "cancelled": self.cancelled,
                "points": [{"pose": p.pose, "target": p.target, "error_mm": p.error_mm, "limit_mm": p.limit_mm,
                            "within": p.within, "error": [float(v) for v in p.error]} for p in self.points],
                "missing": [{"pose": k, "reason": r} for k, r in self.missing]}


def _now() -> datetime:
    return datetime.now(timezone.utc).replace(microsecond=0)


@dataclass
class CheckLimits:
    """Limits (mm) for a set of check configurations: one per point at false-alarm probability
    alpha / (2N), and for the overall RMS at alpha / 2, for points measured with the calibration's
    σ. They depend only on the model, its uncertainty and the poses, so a series of checks
    computes them once; `shared` (3N, 3N) mm², the parameter part of S, serves the limits of
    points measured with their own covariance."""

    per_point: np.ndarray
    rms: float
    alpha: float
    shared: np.ndarray | None = None


def check_limits(model: RobotModel, unc: CalibrationUncertainty, Q, targets, alpha: float = DEFAULT_ALPHA
                 ) -> CheckLimits:
    """The limits for the points at Q (N, n) with their target names (see the module)."""
    Q = np.atleast_2d(np.asarray(Q, dtype=float))
    n = len(Q)
    shared = parameter_covariance(model, unc, Q, targets)
    per = np.array([_limit_of_point(shared, unc, i, None, alpha) for i in range(n)])
    return CheckLimits(per, norm_limit(with_measurement_noise(shared, unc), 1.0 - alpha / 2) / math.sqrt(n),
                       float(alpha), shared)


def _limit_of_point(shared: np.ndarray, unc: CalibrationUncertainty, k: int, own, alpha: float) -> float:
    """Point k's limit (mm) at false-alarm probability alpha / (2N): its block of the parameter
    part `shared` (3N, 3N) plus its measurement noise (own covariance `own`, or None)."""
    block = shared[3 * k:3 * k + 3, 3 * k:3 * k + 3] + unc.measurement_covariance(own)
    return norm_limit(block, 1.0 - alpha / (2 * (len(shared) // 3)))


def _point_limit(limits: CheckLimits, unc: CalibrationUncertainty, k: int, own) -> float:
    """Point k's limit (mm): the precomputed one, or from its own covariance `own`."""
    if own is None:
        return float(limits.per_point[k])
    return _limit_of_point(limits.shared, unc, k, own, limits.alpha)


def _rms_limit(limits: CheckLimits, unc: CalibrationUncertainty, rows: list[int], own: list) -> float:
    """The overall RMS limit (mm) of the points measured (their indices `rows` among the check
    poses, their own covariances `own`)."""
    if len(rows) == len(limits.per_point) and all(c is None for c in own):
        return limits.rms
    idx = np.array([3 * k + a for k in rows for a in range(3)])
    S = with_measurement_noise(limits.shared[np.ix_(idx, idx)], unc, own)
    return norm_limit(S, 1.0 - limits.alpha / 2) / math.sqrt(len(rows))


def run_check(model: RobotModel, unc: CalibrationUncertainty, Q, measure: MeasureFn, *,
              target: str = "marker", tool: str = "", pose_ids=None, log: str | Path | None = None,
              alpha: float = DEFAULT_ALPHA, limits: CheckLimits | None = None, progress=None,
              cancelled=None) -> CheckResult:
    """Measure the `target` at each check configuration Q (N, n; rad / mm) with `measure`,
    compare with `model`'s prediction, append every point to the check `log` at once (with the
    mounted `tool`'s name), and close the check with its overall row. `limits` (from check_limits for the same model, poses
    and alpha) saves computing them again. Cancel stops between poses: what was measured stays
    in the log and the result comes back with `cancelled` (no overall row is written). A pose
    `measure` cannot measure (RoboCalError) is listed as missing; a robot fault (RobotFault) ends
    the check with the points measured so far in the log and no overall row."""
    if not 0.0 < alpha < 0.5:
        raise RoboCalError(f"the false-alarm probability must be between 0 and 0.5, got {alpha}")
    monitor = Monitor(progress, cancelled)
    Q = np.atleast_2d(np.asarray(Q, dtype=float))
    if Q.shape[1] != model.dof:
        raise RoboCalError(f"check poses have {Q.shape[1]} joint values, the robot has {model.dof} joints",
                           hint="Use check poses chosen for this robot.")
    if target not in model.targets:
        raise RoboCalError(f"target '{target}' is not defined in the robot '{model.name}'",
                           hint="Check the target name.")
    ids = np.arange(len(Q)) if pose_ids is None else np.asarray(pose_ids, dtype=int)
    start = datetime.now(timezone.utc)
    run = start.strftime("%Y%m%dT%H%M%S.%fZ")          # one name per check, also two in a second
    targets = [target] * len(Q)
    predicted = predict_points(model, Q, targets)
    if limits is None or len(limits.per_point) != len(Q) or limits.alpha != alpha or limits.shared is None:
        limits = check_limits(model, unc, Q, targets, alpha)
    q_file = np.atleast_2d(model.q_to_file(Q))
    points: list[CheckPoint] = []
    rows: list[int] = []                # the check poses measured, in order
    missing: list[tuple[int, str]] = []
    writer = CheckLogWriter(log, model.dof) if log is not None else None
    stopped = False
    try:
        for k in range(len(Q)):
            try:
                monitor.step(k / len(Q), f"check pose {k + 1} of {len(Q)}")
            except Cancelled:
                stopped = True
                break
            try:
                xyz = measure(Q[k])
            except RobotFault:
                raise                           # the robot stopped: what was measured stays in the log
            except RoboCalError as exc:
                missing.append((int(ids[k]), exc.problem))
                continue
            if xyz is None:
                missing.append((int(ids[k]), "the marker was not found"))
                continue
            own = point_covariance(xyz)
            p = CheckPoint(int(ids[k]), target, q_file[k], Q[k], np.asarray(xyz, dtype=float).reshape(3),
                           predicted[k], _point_limit(limits, unc, k, own), own)
            points.append(p)
            rows.append(k)
            if writer is not None:
                writer.point(run, _now().isoformat(), p.pose, target, p.q_file, p.measured, p.predicted,
                             p.error_mm, p.limit_mm, p.within, tool, p.covariance)
        rms, rms_limit = math.nan, math.nan
        if points:
            rms_limit = _rms_limit(limits, unc, rows, [p.covariance for p in points])
            rms = float(np.sqrt(np.mean([p.error_mm ** 2 for p in points])))
        result = CheckResult(run, start.isoformat(), points, rms, rms_limit, alpha, unc.sigma_mm, missing,
                             cancelled=stopped, log=None if log is None else Path(log), tool=tool)
        if writer is not None and points and not stopped:
            writer.overall(run, _now().isoformat(), rms, rms_limit, result.within, tool)
    finally:
        if writer is not None:
            writer.close()
    if not stopped:
        monitor.step(1.0, "check done")
    return result
