"""Identifying a tool newly mounted on a calibrated arm (a tool changer, the chapter's §6).

Only the tool's target offsets (3 parameters per target, mm in the tool frame) are free; the
arm, the base and every other target keep the calibration as a Gaussian prior with its
covariance (core.monitoring.reidentify), so a few poses determine the offsets and the arm moves
only as far as the data ask. The poses are chosen by observability of the offsets alone
(core.poses.selection.select_poses with every other parameter fixed): well-spread orientations
of the tool, DEFAULT_POSES of them for one target.

Held-out error: each pose's target predicted from the offset fitted to the other poses with the
arm held at the result, |R_k·p₋ₖ + o_k − x_k| (mm), where p₋ₖ is the mean of R_jᵀ·(x_j − o_j)
over j ≠ k (the least-squares offset for a fixed arm) and (R, o) the tool frame at pose k.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np

from core.errors import RoboCalError
from core.kinematics.identifiability import IDENTIFIED
from core.kinematics.jacobian import Parameter, all_parameters, display_value
from core.measurement.file import Measurements
from core.monitoring.reidentify import Reidentification, reidentify
from core.monitoring.uncertainty import CalibrationUncertainty
from core.poses.selection import PoseSelectionResult, minimum_poses, select_poses
from core.robot.model import RobotModel
from core.task import Monitor

DEFAULT_POSES = 5      # for one target: 15 equations for 3 offsets, each pose checked by the others


def tool_parameters(model: RobotModel, tool: str) -> list[Parameter]:
    """The target offsets `tool` carries (x, y, z per target)."""
    return [p for p in all_parameters(model, model.tool_targets(tool)) if p.group == "target"]


def calibrated_targets(model: RobotModel, unc: CalibrationUncertainty, tool: str) -> list[str]:
    """`tool`'s targets whose offsets have a covariance in the calibration (those a check can
    measure), "marker" first when it is one of them."""
    names = set(unc.names)
    out = [t for t in model.tool_targets(tool) if all(f"{t}.{k}" in names for k in "xyz")]
    return sorted(out, key=lambda t: t != "marker")


def calibrated_tools(model: RobotModel, unc: CalibrationUncertainty) -> list[str]:
    """The tools with at least one calibrated target (they can be checked)."""
    return [t for t in model.tool_names() if calibrated_targets(model, unc, t)]


def tool_poses(model: RobotModel, tool: str) -> int:
    """How many poses to propose for identifying `tool`: enough for DEFAULT_POSES measured
    points in all (each pose measures every target of the tool), and at least two more than the
    fewest that determine its offsets."""
    targets = model.tool_targets(tool)
    fixed = [p.name for p in all_parameters(model, targets) if p.group != "target"]
    return max(minimum_poses(model, targets, fixed=fixed) + 2, math.ceil(DEFAULT_POSES / len(targets)))


def propose_tool_poses(model: RobotModel, tool: str, *, count: int | None = None, progress=None, cancelled=None,
                       **options) -> PoseSelectionResult:
    """The few poses that best determine `tool`'s offsets with the arm calibrated; `options` go
    to core.poses.selection.select_poses (rig, plate_size, visibility, floor, candidates, seed …;
    a `target` among them is replaced by the tool's first target)."""
    targets = model.tool_targets(tool)
    fixed = [p.name for p in all_parameters(model, targets) if p.group != "target"]
    count = tool_poses(model, tool) if count is None else int(count)
    options.pop("target", None)
    options.setdefault("random_trials", 20)
    options.setdefault("curve_max", count)
    return select_poses(model, count, target=targets[0], targets=targets, fixed=fixed, progress=progress,
                        cancelled=cancelled, **options)


@dataclass
class ToolIdentification:
    """A tool's identified offsets (mm, tool frame), their covariance (mm², in `parameters`' order),
    the errors on the poses used (mm) and held out, and the updated calibrated model (written with
    core.monitoring.reidentify.write_reidentified(result.reidentification, path))."""

    tool: str
    offsets: dict[str, np.ndarray]
    parameters: list[str]
    covariance: np.ndarray
    held_out_mm: np.ndarray            # per measured point, predicted from the other poses
    reidentification: Reidentification

    @property
    def model(self) -> RobotModel:
        return self.reidentification.model

    @property
    def std_mm(self) -> np.ndarray:
        return np.sqrt(np.clip(np.diag(self.covariance), 0.0, None))

    @property
    def sigma_mm(self) -> float:
        """The predicted RMS length of the offset's error, √trace(C) (mm, one target: the whole tool)."""
        return float(math.sqrt(max(np.trace(self.covariance), 0.0)))

    @property
    def held_out_rms_mm(self) -> float:
        return float(np.sqrt(np.mean(self.held_out_mm ** 2)))

    @property
    def n_poses(self) -> int:
        return self.reidentification.n_poses

    def text(self) -> str:
        parts = [f"{t} ({', '.join(f'{v:.2f}' for v in p)}) mm" for t, p in self.offsets.items()]
        return (f"Tool '{self.tool}' identified from {self.n_poses} poses: {'; '.join(parts)} in the tool frame, "
                f"± {self.sigma_mm:.3f} mm; error {self.reidentification.rms_after_mm:.3f} mm RMS on those poses, "
                f"{self.held_out_rms_mm:.3f} mm on each pose predicted from the others.")

    def summary(self) -> dict:
        return {"tool": self.tool, "offsets_mm": {t: [float(v) for v in p] for t, p in self.offsets.items()},
                "std_mm": dict(zip(self.parameters, (float(v) for v in self.std_mm))),
                "sigma_mm": self.sigma_mm, "n_poses": self.n_poses,
                "rms_before_mm": self.reidentification.rms_before_mm,
                "rms_after_mm": self.reidentification.rms_after_mm, "held_out_rms_mm": self.held_out_rms_mm}


def held_out_errors(model: RobotModel, meas: Measurements) -> np.ndarray:
    """Per point, the error of its target predicted from the other poses' offset (see the module), mm."""
    T = model.fk_many(meas.Q)
    local = np.einsum("nji,nj->ni", T[:, :3, :3], meas.xyz - T[:, :3, 3])     # R_jᵀ·(x_j − o_j)
    names = np.asarray(meas.target)
    out = np.zeros(len(names))
    for t in dict.fromkeys(meas.target):
        rows = np.flatnonzero(names == t)
        if len(rows) < 2:
            raise RoboCalError(f"target '{t}' was measured at {len(rows)} pose(s); a tool needs at least 2",
                               hint="Measure the proposed poses (robocal identify-tool proposes them).")
        total = local[rows].sum(axis=0)
        for k in rows:
            p = (total - local[k]) / (len(rows) - 1)
            out[k] = np.linalg.norm(T[k, :3, :3] @ p + T[k, :3, 3] - meas.xyz[k])
    return out


def identify_tool(model: RobotModel, unc: CalibrationUncertainty, tool: str, meas: Measurements, *,
                  previous: str = "", alpha: float = 0.01, progress=None, cancelled=None) -> ToolIdentification:
    """Identify `tool`'s target offsets from `meas` (its targets at a few poses) with the calibrated
    arm as the prior (see the module). The updated model's calibration lists the tool, has rows for
    its offsets and a history entry. Raises RoboCalError when the points name other targets or
    the fit does not explain them (nothing is to be written then)."""
    monitor = Monitor(progress, cancelled)
    targets = model.tool_targets(tool)
    other = sorted(set(meas.target) - set(targets))
    if other:
        raise RoboCalError(f"the measurements hold target(s) {', '.join(other)}, not on tool '{tool}' "
                           f"(its targets: {', '.join(targets)})", source=meas.source or None, field="target",
                           hint="Give the measurements of this tool's proposed poses.")
    params = tool_parameters(model, tool)
    known = set(unc.names)
    re = reidentify(model, unc, params, meas, reason=f"tool '{tool}' mounted and identified", previous=previous,
                    alpha=alpha, progress=monitor.sub(0.0, 0.9), cancelled=cancelled)
    fitted = meas.with_robot(re.model) if meas.Q is None else meas
    held = held_out_errors(re.model, fitted)
    index = [k for k, p in enumerate(re.parameters) if p.name in {q.name for q in params}]
    cov = re.covariance[np.ix_(index, index)]
    _record_tool(re.model.calibration, model, re.model, [p for p in params if p.name not in known], cov,
                 [re.parameters[k] for k in index], tool, float(np.sqrt(np.mean(held ** 2))))
    monitor.step(1.0, f"tool '{tool}' identified")
    offsets = {t: np.asarray(re.model.targets[t], dtype=float).copy() for t in targets}
    return ToolIdentification(tool, offsets, [re.parameters[k].name for k in index], cov, held, re)


def _record_tool(cal: dict, before: RobotModel, after: RobotModel, new: Sequence[Parameter], cov: np.ndarray,
                 params: Sequence[Parameter], tool: str, held_out_rms: float) -> None:
    """The tool in the calibration section (in place): listed among the calibrated tools, a row per
    offset the table lacked, and its name and held-out error in the history entry just added."""
    std = dict(zip((p.name for p in params), np.sqrt(np.clip(np.diag(cov), 0.0, None))))
    rows = cal.setdefault("parameters", [])
    for p in new:
        rows.append({"name": p.name, "unit": p.unit, "nominal": display_value(before, p),
                     "identified": display_value(after, p), "std": float(std[p.name]), "identifiable": True,
                     "status": IDENTIFIED, "explanation": f"identified with tool '{tool}' after the calibration"})
    tools = list(cal.get("tools", []) or [])
    cal["tools"] = tools + ([tool] if tool not in tools else [])
    cal["history"][-1].update({"tool": tool, "held_out_rms_mm": held_out_rms})
