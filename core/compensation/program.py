"""Corrected programs: Cartesian targets or a nominal joint program turned into the joints that
put the calibrated robot where they mean, and the Cartesian targets a controller that keeps its
nominal kinematics must be given instead.

* `compensate_targets(calibrated, targets, ...)`: targets (core.compensation.targets) in the
  robot's base frame, the measurement (left camera) frame or a fixture frame → joints by
  `solve_ik` with the calibrated model; the targets' q columns, if any, pick the branch.
* `compensate_program(calibrated, nominal, Q_nominal, ...)`: a joint program made with the
  nominal model → the nominal model's tool-point poses in its base frame (what the program
  meant) → the calibrated model's joints for those poses in its base frame, branch of each
  point nearest its nominal joints.
* `CompensatedProgram.controller_poses()`: with the nominal model, the nominal forward
  kinematics of the corrected joints in the nominal base frame (`--for-controller cartesian`):
  a controller that computes its joints with the nominal model from these poses lands on the
  corrected joints.

The correction of a point (`correction_mm`, needs the nominal model) is how far the controller's
nominal model believes the tool point moved: |nominal position at the corrected joints −
intended position|, both in the base frame. Predicted errors come from the calibrated file's
covariance (core.compensation.prediction); a robot file without one gives none.
Units: mm, deg in files; Q internal (rad / mm).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from core import transforms as tf
from core.compensation.ik import IKResult, solve_ik, tcp_poses
from core.compensation.prediction import PredictedError, predicted_error
from core.compensation.targets import TargetList
from core.errors import RoboCalError
from core.robot.model import RobotModel
from core.task import Monitor


@dataclass
class CompensatedProgram:
    """The corrected joints of a program and what goes with them. `intended_base` (N, 4, 4): the
    tool point's intended poses in the calibrated model's base frame; `reference_Q` (N, n): the
    nominal program's joints (program mode) or None; `predicted` None without a covariance."""

    names: list[str]
    ik: IKResult
    calibrated: RobotModel
    intended_base: np.ndarray
    tcp: str
    nominal: RobotModel | None = None
    reference_Q: np.ndarray | None = None
    predicted: PredictedError | None = None
    no_prediction: str = ""

    @property
    def Q(self) -> np.ndarray:
        return self.ik.Q

    @property
    def ok(self) -> np.ndarray:
        return self.ik.ok

    @property
    def q_file(self) -> np.ndarray:
        """The corrected joints in file units (deg / mm); −0 written as 0."""
        q = self.calibrated.q_to_file(self.ik.Q).reshape(self.ik.Q.shape)
        return np.where(np.abs(q) < 5e-7, 0.0, q)

    def joint_correction_file(self) -> np.ndarray | None:
        """Corrected − nominal program joints (deg / mm), program mode only."""
        if self.reference_Q is None:
            return None
        return self.calibrated.q_to_file(self.ik.Q - self.reference_Q).reshape(self.ik.Q.shape)

    def controller_poses(self) -> np.ndarray:
        """The nominal model's tool-point poses (N, 4, 4) at the corrected joints, in the nominal
        base frame: what a controller with nominal kinematics is given."""
        if self.nominal is None:
            raise RoboCalError("corrected Cartesian targets need the nominal robot model",
                               hint="Give the robot file the controller's kinematics come from (--nominal).")
        return tf.invert(self.nominal.base) @ tcp_poses(self.nominal, self.ik.Q, self.tcp)

    def correction_mm(self) -> np.ndarray | None:
        """How far the correction moves the tool point in the nominal model's eyes (N,), mm."""
        if self.nominal is None:
            return None
        return np.linalg.norm(self.controller_poses()[:, :3, 3] - self.intended_base[:, :3, 3], axis=1)

    def failures(self) -> list[tuple[int, str]]:
        return [(i, r) for i, r in enumerate(self.ik.reason) if not self.ik.ok[i]]

    def summary(self) -> str:
        """One paragraph: points corrected, largest correction, predicted error."""
        n = len(self.names)
        parts = [f"{int(self.ok.sum())} of {n} points corrected for the tool point '{self.tcp}'"]
        corr = self.correction_mm()
        if corr is not None and n:
            k = int(np.argmax(corr))
            parts.append(f"largest correction {corr[k]:.3f} mm at '{self.names[k]}' (median {np.median(corr):.3f} mm)")
        dq = self.joint_correction_file()
        if dq is not None and n:
            i, j = np.unravel_index(int(np.argmax(np.abs(dq))), dq.shape)
            unit = "°" if self.calibrated.joints[j].revolute else " mm"
            parts.append(f"largest joint change {dq[i, j]:+.4f}{unit} (q{j + 1} at '{self.names[i]}')")
        if self.predicted is not None and n:
            p = self.predicted
            k = int(np.argmax(p.limit_mm))
            parts.append(f"predicted error σ {np.median(p.sigma_mm):.3f} mm (median), "
                         f"{100 * p.probability:g} % within {p.limit_mm[k]:.3f} mm at worst ('{self.names[k]}')")
        elif self.no_prediction:
            parts.append(self.no_prediction)
        return "; ".join(parts) + "."

    def table(self) -> list[dict]:
        """One row per point (names, corrected joints deg / mm, ok, reason, correction, predicted)."""
        corr = self.correction_mm()
        dq = self.joint_correction_file()
        rows = []
        for i, name in enumerate(self.names):
            row = {"name": name, "q": [float(v) for v in self.q_file[i]], "ok": bool(self.ok[i]),
                   "reason": self.ik.reason[i], "ik_error_mm": float(self.ik.error_mm[i])}
            if corr is not None:
                row["correction_mm"] = float(corr[i])
            if dq is not None:
                row["joint_correction"] = [float(v) for v in dq[i]]
            if self.predicted is not None:
                row["predicted_sigma_mm"] = float(self.predicted.sigma_mm[i])
                row["predicted_limit_mm"] = float(self.predicted.limit_mm[i])
            rows.append(row)
        return rows


def _predict(model: RobotModel, Q, tcp: str, probability: float):
    if not isinstance(model.calibration, dict) or "covariance" not in model.calibration:
        return None, "no predicted error: the robot file holds no calibration covariance"
    return predicted_error(model, Q, tcp, probability=probability), ""


def compensate_targets(calibrated: RobotModel, targets: TargetList, *, tcp: str = "marker", frame="base",
                       nominal: RobotModel | None = None, orientation: bool = True, probability: float = 0.95,
                       progress=None, cancelled=None) -> CompensatedProgram:
    """The calibrated robot's joints for each target (see the module). `frame` as `solve_ik`;
    `orientation` False ignores the targets' roll, pitch, yaw."""
    monitor = Monitor(progress, cancelled)
    monitor.step(0.0, "inverse kinematics")
    hint = None
    if targets.hint_file is not None:
        if targets.hint_file.shape[1] != calibrated.dof:
            raise RoboCalError(f"the targets give {targets.hint_file.shape[1]} joint columns but the robot has "
                               f"{calibrated.dof} joints", source=targets.path, hint="Give q1 … qn for every joint.")
        hint = calibrated.q_from_file(targets.hint_file).reshape(targets.hint_file.shape)
    R = targets.rotations if orientation else None
    ik = solve_ik(calibrated, targets.xyz, R, tcp=tcp, frame=frame, hint=hint)
    monitor.step(0.8, "predicted error")
    intended = tf.invert(calibrated.base) @ ik.targets_world
    pred, note = _predict(calibrated, ik.Q, tcp, probability)
    monitor.step(1.0, "done")
    return CompensatedProgram(list(targets.names), ik, calibrated, intended, tcp, nominal, None, pred, note)


def compensate_program(calibrated: RobotModel, nominal: RobotModel, Q_nominal, *, tcp: str = "marker",
                       names: list[str] | None = None, orientation: bool = True, probability: float = 0.95,
                       progress=None, cancelled=None) -> CompensatedProgram:
    """The calibrated robot's joints for what the nominal joint program Q_nominal (N, n,
    internal units) meant (see the module); `orientation` False matches positions only (a
    robot of fewer than 6 joints always does)."""
    monitor = Monitor(progress, cancelled)
    Q_nominal = np.atleast_2d(np.asarray(Q_nominal, dtype=float))
    if nominal.dof != calibrated.dof:
        raise RoboCalError(f"the nominal robot '{nominal.name}' has {nominal.dof} joints but the calibrated "
                           f"'{calibrated.name}' has {calibrated.dof}",
                           hint="Give the nominal model of the same robot.")
    if Q_nominal.shape[1] != nominal.dof:
        raise RoboCalError(f"the program has {Q_nominal.shape[1]} joint columns but the robot has {nominal.dof}",
                           hint="Give the program taught for this robot.")
    monitor.step(0.0, "inverse kinematics")
    meant = tf.invert(nominal.base) @ tcp_poses(nominal, Q_nominal, tcp)
    use_R = orientation and calibrated.dof >= 6
    ik = solve_ik(calibrated, meant[:, :3, 3], meant[:, :3, :3] if use_R else None, tcp=tcp, frame="base",
                  hint=Q_nominal)
    monitor.step(0.8, "predicted error")
    pred, note = _predict(calibrated, ik.Q, tcp, probability)
    labels = list(names) if names is not None else [str(i) for i in range(len(Q_nominal))]
    monitor.step(1.0, "done")
    return CompensatedProgram(labels, ik, calibrated, meant, tcp, nominal, Q_nominal, pred, note)
