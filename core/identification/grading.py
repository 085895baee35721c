"""Grading a calibration against the true robot it was made of (a virtual lab's, for teaching).

Two comparisons:

* **parameters**: every joint parameter the student's calibration identified (its file gives a
  ± σ) against the true value as the student's model can express it (`reachable_truth`: a
  parameter the calibration kept at nominal shifts the others it correlates with, whoever
  calibrates). J1.θ and J1.d are never compared: they move the whole arm as the
  base rotation about and the shift along the first joint axis do, so the fit keeps them at
  nominal and the base pose absorbs them; the base pose and the marker offset are not compared
  either, as they absorb those (and the last joint's) errors. J6.* are compared only when the
  calibration identified them (with the marker's orientation): a marker on the last joint's axis
  does not move when that joint turns, so positions alone leave them at nominal. Parameters fixed
  at nominal (Hayati's d, the user's --fix) are listed, not compared. A parameter passes when
  |student − truth| ≤ k·σ, σ² = σ_student² + σ_stereo², where σ_stereo is the part of the
  parameter's error due to the stereo calibration, which the student's σ leaves out: the shift
  of the parameter that fitting the stereo calibration's point errors alone gives (a systematic
  error, the same at every pose, so the fit's scatter σ̂ does not see it).
* **fresh poses**: the student's model against the true marker positions at configurations the
  calibration never saw, after the best rigid alignment (mm: the robot's own accuracy, as the
  Identification page shows it; where the stereo calibration put the frame is left out); it
  passes when the RMS error is within k times the one expected from the student's covariance
  and the part of the stereo calibration's error a rigid motion does not remove.

Units: mm and deg in the result (internal mm, rad in the computations).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from core.errors import RoboCalError
from core.kinematics.jacobian import (Parameter, all_parameters, apply_step, calibration_jacobian,
                                      predict_points)
from core.identification.model_comparison import compare_models
from core.robot.model import RobotModel
from core.transforms import kabsch, transform_points

#: a parameter or the fresh-pose RMS passes within this many standard deviations
DEFAULT_K = 3.0

ABSORBED_BY_BASE = ("not compared: it moves the whole arm as the base pose does (J1.theta: a turn about the "
                    "first joint axis, J1.d: a shift along it), so the calibration keeps it at nominal and the "
                    "base pose absorbs it; no measurement of the marker can tell them apart")
LAST_JOINT = ("not compared: the marker sits on the last joint's axis, so its position alone cannot separate "
              "the last joint's geometry from the marker's offset (identify with --orientation to estimate it)")
BASE_OR_MARKER = ("not compared: the base pose and the marker offset absorb J1.theta, J1.d and the last "
                  "joint's errors, so they differ from the truth by those; the fresh poses judge them")
FIXED = "not compared: kept at its nominal value by the calibration ({status})"


@dataclass
class GradedParameter:
    """One compared parameter, display units (mm or deg)."""

    name: str
    unit: str
    student: float
    truth: float
    sigma_student: float
    sigma_stereo: float
    k: float

    @property
    def difference(self) -> float:
        return self.student - self.truth

    @property
    def sigma(self) -> float:
        return math.hypot(self.sigma_student, self.sigma_stereo)

    @property
    def tolerance(self) -> float:
        return self.k * self.sigma

    @property
    def passed(self) -> bool:
        return abs(self.difference) <= self.tolerance

    def to_dict(self) -> dict:
        return {"name": self.name, "unit": self.unit, "student": self.student, "truth": self.truth,
                "difference": self.difference, "sigma_student": self.sigma_student,
                "sigma_stereo": self.sigma_stereo, "tolerance": self.tolerance, "passed": self.passed}


@dataclass
class GradeResult:
    """The mark sheet: compared parameters, the ones left out and why, and the fresh poses."""

    parameters: list[GradedParameter]
    excluded: dict[str, str]
    fresh_poses: int
    fresh_rms_mm: float
    fresh_max_mm: float
    expected_rms_mm: float
    stereo_error: str                  # where the stereo calibration's error came from, in words
    k: float = DEFAULT_K
    notes: list[str] = field(default_factory=list)
    frame_rms_mm: float = math.nan     # the same before the alignment (the stereo frame's error included)

    @property
    def fresh_passed(self) -> bool:
        return self.fresh_rms_mm <= self.k * self.expected_rms_mm

    @property
    def marks(self) -> int:
        """One mark per parameter within tolerance, one for the fresh poses."""
        return sum(p.passed for p in self.parameters) + int(self.fresh_passed)

    @property
    def out_of(self) -> int:
        return len(self.parameters) + 1

    def to_dict(self) -> dict:
        return {"marks": self.marks, "out_of": self.out_of, "k": self.k,
                "parameters": [p.to_dict() for p in self.parameters],
                "not_compared": [{"name": n, "reason": r} for n, r in self.excluded.items()],
                "fresh_poses": {"count": self.fresh_poses, "rms_mm": self.fresh_rms_mm, "max_mm": self.fresh_max_mm,
                                "camera_frame_rms_mm": self.frame_rms_mm,
                                "expected_rms_mm": self.expected_rms_mm, "passed": self.fresh_passed},
                "stereo_error": self.stereo_error, "notes": list(self.notes)}

    def text(self) -> str:
        lines = [f"Mark sheet: {self.marks} of {self.out_of} marks "
                 f"({sum(p.passed for p in self.parameters)} of {len(self.parameters)} parameters within "
                 f"{self.k:g}σ of the truth, fresh poses {'passed' if self.fresh_passed else 'failed'})",
                 f"  σ = √(σ_student² + σ_stereo²); stereo calibration error: {self.stereo_error}",
                 f"  {'parameter':<10} {'student':>10} {'truth':>10} {'diff':>9} {'σ_stud':>8} {'σ_stereo':>8} "
                 f"{'±tol':>8}  mark"]
        for p in self.parameters:
            lines.append(f"  {p.name:<10} {p.student:>10.4f} {p.truth:>10.4f} {p.difference:>+9.4f} "
                         f"{p.sigma_student:>8.4f} {p.sigma_stereo:>8.4f} {p.tolerance:>8.4f}  "
                         f"{'ok' if p.passed else 'OFF'} {p.unit}")
        lines.append(f"  fresh poses ({self.fresh_poses}, never measured), after the best rigid alignment: RMS "
                     f"{self.fresh_rms_mm:.3f} mm, max {self.fresh_max_mm:.3f} mm; expected {self.expected_rms_mm:.3f} mm "
                     f"-> {'ok' if self.fresh_passed else 'OFF'} (within {self.k:g}× the expected RMS)")
        lines.append(f"    (in the camera frame, before the alignment: RMS {self.frame_rms_mm:.3f} mm; the difference is "
                     "where the stereo calibration put the frame)")
        lines.append("Not compared:")
        for name, reason in self.excluded.items():
            lines.append(f"  {name}: {reason}")
        lines += [f"Note: {n}" for n in self.notes]
        return "\n".join(lines)


def _value(model: RobotModel, p: Parameter) -> float:
    return float(getattr(model.joints[p.joint], p.kind) * p.to_display)


def reachable_truth(student: RobotModel, truth: RobotModel, Q: np.ndarray, targets: list[str],
                    estimated: list[Parameter], iterations: int = 10) -> RobotModel:
    """The truth as the student's model can express it: the student's model with its estimated
    parameters fitted (Gauss–Newton, no noise) to the true positions at Q, everything else kept
    where the calibration kept it. A parameter kept at nominal (J1.θ, Hayati's d, one the poses
    barely determined) is then absorbed exactly as in the calibration, so what is left to compare
    is the student's error, not the model's structure."""
    model = student
    goal = predict_points(truth, Q, targets).reshape(-1)
    for _ in range(iterations):
        r = goal - predict_points(model, Q, targets).reshape(-1)
        phi = calibration_jacobian(model, Q, targets, estimated)
        step = np.linalg.lstsq(phi, r, rcond=1e-12)[0]
        model = apply_step(model, estimated, step)
        if float(np.max(np.abs(r))) < 1e-9:
            break
    return model


def _calibration_rows(student: RobotModel, source) -> tuple[dict[str, dict], list[str]]:
    cal = student.calibration
    rows = cal.get("parameters") if isinstance(cal, dict) else None
    cov = cal.get("covariance") if isinstance(cal, dict) else None
    if not isinstance(rows, list) or not isinstance(cov, dict) or not isinstance(cov.get("parameters"), list):
        raise RoboCalError("this robot file holds no calibration to grade", source=source, field="calibration",
                           hint="Give the calibrated robot file written by robocal identify.")
    return {r.get("name"): r for r in rows if isinstance(r, dict)}, [str(n) for n in cov["parameters"]]


def grade_calibration(student: RobotModel, truth: RobotModel, Q: np.ndarray, target: str, *,
                      stereo_shift: np.ndarray | None = None, k: float = DEFAULT_K, source=None) -> GradeResult:
    """Grade `student` (a calibrated robot file's model) against `truth` (same joints, its
    measurement frame the student's) at fresh configurations Q (M, n, internal units) of the
    marker `target`. `stereo_shift` (M, 3) mm: where the student's stereo calibration puts the
    true marker positions at Q, minus those positions; None: left out (σ_stereo = 0, with a note)."""
    Q = np.atleast_2d(np.asarray(Q, dtype=float))
    if student.dof != truth.dof or Q.shape[1] != truth.dof:
        raise RoboCalError(f"the calibrated robot has {student.dof} joints, the lab's {truth.dof}", source=source,
                           hint="Grade against the lab robot the calibration was made in (--lab-robot).")
    if target not in student.targets:
        raise RoboCalError(f"the calibrated robot has no '{target}' target", source=source, field="targets")
    rows, estimated = _calibration_rows(student, source)
    params = {p.name: p for p in all_parameters(student, [target], orientation_targets=[target])}
    unknown = [n for n in estimated if n not in params]
    if unknown:
        raise RoboCalError(f"unknown parameter '{unknown[0]}' for this robot", source=source,
                           field="calibration.covariance.parameters")
    est = [params[n] for n in estimated]
    targets = [target] * len(Q)
    phi = calibration_jacobian(student, Q, targets, est)                     # (3M, p), mm per internal unit
    notes = []
    if stereo_shift is not None:
        shift = np.asarray(stereo_shift, dtype=float).reshape(-1)
        stereo_delta = np.abs(np.linalg.lstsq(phi, shift, rcond=1e-10)[0])
        stereo_rms = float(np.sqrt(np.mean(np.sum(shift.reshape(-1, 3) ** 2, axis=1))))
        true_points = predict_points(truth, Q, targets)
        moved = true_points + shift.reshape(-1, 3)
        stereo_nonrigid = float(np.sqrt(np.mean(np.sum(
            (transform_points(kabsch(moved, true_points), moved) - true_points) ** 2, axis=1))))
        stereo_words = (f"RMS {stereo_rms:.3f} mm at the fresh poses ({stereo_nonrigid:.3f} mm after the best "
                        "rigid alignment), from the stereo calibration given")
    else:
        stereo_delta, stereo_nonrigid = np.zeros(len(est)), 0.0
        stereo_words = "not given (σ_stereo = 0)"
        notes.append("without the stereo calibration the tolerances leave out its error, which usually dominates: "
                     "a good calibration may be marked off; give --stereo")
    sigma_stereo = {p.name: float(d * p.to_display) for p, d in zip(est, stereo_delta)}

    reachable = reachable_truth(student, truth, Q, targets, est)
    graded, excluded = [], {}
    for p in all_parameters(student, [target]):
        row = rows.get(p.name, {})
        std = row.get("std")
        if p.group != "joint":
            continue
        if p.joint == 0 and p.kind in ("theta", "d"):
            excluded[p.name] = ABSORBED_BY_BASE
        elif std is None or p.name not in sigma_stereo:
            status = str(row.get("status", "not identifiable"))
            if status.startswith("fixed") or status == "fixed":
                excluded[p.name] = FIXED.format(status=status)
            elif p.joint == student.dof - 1:
                excluded[p.name] = LAST_JOINT
            else:
                excluded[p.name] = f"not compared: {row.get('explanation') or status}"
        else:
            graded.append(GradedParameter(p.name, p.unit, _value(student, p), _value(reachable, p), float(std),
                                          sigma_stereo[p.name], k))
    excluded["base.*, marker.*"] = BASE_OR_MARKER

    fresh = compare_models(truth, student, Q, [target], align=True)
    cov_entry = student.calibration["covariance"]
    try:
        cov = np.asarray(cov_entry.get("matrix"), dtype=float)
    except (TypeError, ValueError):
        cov = np.zeros((0, 0))
    if cov.shape != (len(est), len(est)) or not np.all(np.isfinite(cov)) or cov_entry.get("units") != "mm and rad":
        raise RoboCalError(f"expected a {len(est)} × {len(est)} matrix of numbers in mm and rad", source=source,
                           field="calibration.covariance.matrix", hint="Identify again to write a complete file.")
    predicted = np.einsum("ij,jk,ik->i", phi, cov, phi)                       # per row variance, mm²
    expected = math.sqrt(float(np.mean(predicted.reshape(-1, 3).sum(axis=1))) + stereo_nonrigid ** 2)
    return GradeResult(graded, excluded, len(Q), fresh.rms_mm, fresh.max_mm, expected, stereo_words, k, notes,
                       frame_rms_mm=fresh.raw_rms_mm)
