"""The accuracy map: how far from a grid of targets the robot's marker really lands, reached with
the nominal model (what the controller knows: before) and with the calibrated model (after),
each landing measured by the cameras.

Frames: targets and measured points in the measurement frame (left camera, mm); the map is drawn
in the robot base frame (DH frame 0 of the calibrated model). The nominal model is placed where
the cameras found the robot (`nominal_in_cell`): "before" holds only the kinematic errors the
controller keeps, not the robot's placement.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from core.compensation.ik import solve_ik
from core.compensation.workspace_grid import WorkspaceGrid
from core.errors import Cancelled
from core.robot.model import RobotModel
from core.task import Monitor

#: `measure(q)`: the robot moved to q (rad / mm), the marker located by the cameras (mm,
#: measurement frame), or None when it was not found
Measure = Callable[[np.ndarray], "np.ndarray | None"]


@dataclass
class AccuracyMap:
    """Targets and where the marker landed with the nominal and with the calibrated joints.

    `targets`, `before`, `after`: (n, 3) mm, measurement frame; NaN where not measured.
    `q_before`, `q_after`: (n, dof) rad / mm; NaN where the model cannot reach the target.
    `base`: the robot base in the measurement frame (4x4, the calibrated model's).
    `notes`: per target why it was not measured ("" when it was).
    `measured_by`: where the landings were measured (virtual lab, a serial robot …)."""

    targets: np.ndarray
    before: np.ndarray
    after: np.ndarray
    q_before: np.ndarray
    q_after: np.ndarray
    base: np.ndarray
    measured_by: str
    notes: list[str] = field(default_factory=list)
    robot: str = ""
    cancelled: bool = False

    @property
    def n(self) -> int:
        return len(self.targets)

    @property
    def both(self) -> np.ndarray:
        """Targets measured both before and after (bool, n)."""
        return np.all(np.isfinite(self.before), axis=1) & np.all(np.isfinite(self.after), axis=1)

    def _in_base(self, points: np.ndarray) -> np.ndarray:
        inv = np.linalg.inv(self.base)
        return points @ inv[:3, :3].T + inv[:3, 3]

    @property
    def targets_base(self) -> np.ndarray:
        """Targets in the robot base frame (n, 3) mm."""
        return self._in_base(self.targets)

    @property
    def vectors_before(self) -> np.ndarray:
        """Landing − target with the nominal model, robot base axes (n, 3) mm."""
        return (self.before - self.targets) @ self.base[:3, :3]

    @property
    def vectors_after(self) -> np.ndarray:
        """Landing − target with the calibrated model, robot base axes (n, 3) mm."""
        return (self.after - self.targets) @ self.base[:3, :3]

    @property
    def errors_before(self) -> np.ndarray:
        """Position error per target measured both ways (mm)."""
        return np.linalg.norm(self.before - self.targets, axis=1)[self.both]

    @property
    def errors_after(self) -> np.ndarray:
        return np.linalg.norm(self.after - self.targets, axis=1)[self.both]

    @staticmethod
    def _rms(e: np.ndarray) -> float:
        return float(np.sqrt(np.mean(e ** 2))) if len(e) else float("nan")

    @property
    def rms_before_mm(self) -> float:
        return self._rms(self.errors_before)

    @property
    def rms_after_mm(self) -> float:
        return self._rms(self.errors_after)

    @property
    def max_before_mm(self) -> float:
        return float(self.errors_before.max()) if self.both.any() else float("nan")

    @property
    def max_after_mm(self) -> float:
        return float(self.errors_after.max()) if self.both.any() else float("nan")

    @property
    def improvement(self) -> float:
        """RMS before / RMS after (how many times more accurate); NaN without points."""
        before, after = self.rms_before_mm, self.rms_after_mm
        return before / after if after > 0 else float("nan")

    def summary(self) -> str:
        """One line for a technician."""
        if not self.both.any():
            return f"No target was measured both ways ({self.measured_by})."
        return (f"{int(self.both.sum())} of {self.n} targets measured ({self.measured_by}): RMS error "
                f"{self.rms_before_mm:.2f} mm with the nominal model, {self.rms_after_mm:.3f} mm with the "
                f"calibrated model — {self.improvement:.0f}× more accurate"
                + (" (cancelled before the end)" if self.cancelled else "") + ".")


def nominal_in_cell(nominal: RobotModel, calibrated: RobotModel) -> RobotModel:
    """The nominal model placed where the cameras found the robot: the calibrated base, the
    nominal joints and tool, the nominal targets (the calibrated ones it lacks)."""
    out = nominal.copy()
    out.base = np.array(calibrated.base, dtype=float)
    for name, p in calibrated.targets.items():
        out.targets.setdefault(name, np.array(p, dtype=float))
    return out


def run_accuracy_map(nominal: RobotModel, calibrated: RobotModel, grid: WorkspaceGrid, measure: Measure, *,
                     measured_by: str, robot: str = "", progress=None, cancelled=None) -> AccuracyMap:
    """Reach every target of `grid` with the nominal model (placed by `nominal_in_cell`) and
    with the `calibrated` one, move there (`measure`) and record where the marker landed.
    Cancel keeps the targets measured so far (`cancelled` set)."""
    monitor = Monitor(progress, cancelled)
    monitor.step(0.0, "joints of the targets with both models")
    after = solve_ik(calibrated, grid.points, tcp=grid.target, frame="measurement", hint=grid.hints)
    # the nominal model starts from the calibrated joints: the same branch, a few mm away
    before = solve_ik(nominal_in_cell(nominal, calibrated), grid.points, tcp=grid.target, frame="measurement",
                      hint=np.where(after.ok[:, None], after.Q, grid.hints))
    (q_before, notes_before), (q_after, notes_after) = [(np.where(s.ok[:, None], s.Q, np.nan), s.reason)
                                                        for s in (before, after)]
    n = len(grid.points)
    landed = {"before": np.full((n, 3), np.nan), "after": np.full((n, 3), np.nan)}
    notes = [""] * n
    stopped = False
    try:
        for i in range(n):
            for k, (name, q, why) in enumerate((("before", q_before[i], notes_before[i]),
                                                ("after", q_after[i], notes_after[i]))):
                monitor.step((2 * i + k) / (2 * n), f"target {i + 1} of {n}, {'calibrated' if k else 'nominal'} model")
                if why:
                    notes[i] = notes[i] or f"{'calibrated' if k else 'nominal'} model: {why}"
                    continue
                p = measure(q)
                if p is None:
                    notes[i] = notes[i] or f"marker not found ({'calibrated' if k else 'nominal'} model)"
                else:
                    landed[name][i] = np.asarray(p, dtype=float)
        monitor.step(1.0, "done")
    except Cancelled:
        stopped = True
    return AccuracyMap(grid.points.copy(), landed["before"], landed["after"], q_before, q_after,
                       np.array(calibrated.base, dtype=float), measured_by, notes, robot, stopped)
