"""Whether a calibration keeps the deflection terms (core.robot.compliance): cross validation
grouped by pose and the one-standard-error rule, with the verdict in plain words.

`--compliance auto` fits the model with and without the terms on the same poses, then predicts
every pose once by models fitted on the other poses (k folds of whole poses, so the several
targets of one pose never sit on both sides). Each pose's error is the mean 3D error of its
points. The terms are kept only when their cross-validated mean error plus its standard error
(over poses) is still below the geometry-only one — the one-standard-error rule: the simpler
model wins unless the richer one is better by more than the scatter of the estimate. Points
whose target the training poses of a fold did not measure (a reflector measured in one pose
only) cannot be predicted by that fold and are left out for both models alike.

The weights of the ridge on the terms (and of the prior toward nominal, when asked for) are
estimated once on all poses and kept for every fold, as identification's own k-fold does.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable, Sequence

import numpy as np

from core.kinematics.jacobian import predict_points
from core.measurement.file import Measurements
from core.robot.model import RobotModel
from core.task import Monitor

OFF, ON, AUTO = "off", "on", "auto"
MODES = (OFF, ON, AUTO)
FOLDS = 5


@dataclass
class ComplianceChoice:
    """What the calibration did with the deflection terms, and why (mm)."""

    mode: str                          # OFF | ON | AUTO (what was asked)
    kept: bool                         # the calibrated model has the terms
    verdict: str                       # plain words for the screen, the output and the record
    n_poses: int = 0                   # poses the cross validation predicted (AUTO)
    folds: int = 0
    cv_mean_off_mm: float | None = None
    cv_mean_on_mm: float | None = None
    standard_error_mm: float | None = None
    weight: float | None = None        # λ_C of the ridge on the terms (core.identification.prior)

    @property
    def gain_mm(self) -> float | None:
        if self.cv_mean_off_mm is None or self.cv_mean_on_mm is None:
            return None
        return self.cv_mean_off_mm - self.cv_mean_on_mm

    def summary(self) -> dict:
        out = {"mode": self.mode, "kept": self.kept, "verdict": self.verdict}
        if self.mode == AUTO:
            out.update({"n_poses": self.n_poses, "folds": self.folds, "cv_mean_off_mm": self.cv_mean_off_mm,
                        "cv_mean_on_mm": self.cv_mean_on_mm, "standard_error_mm": self.standard_error_mm})
        if self.weight is not None:
            out["ridge_weight"] = self.weight
        return out


def per_pose_errors(model: RobotModel, meas: Measurements, known: set[str]) -> dict[int, float]:
    """Mean 3D error (mm) of each pose's points whose target is in `known`."""
    keep = np.array([t in known for t in meas.target], dtype=bool)
    if not keep.any():
        return {}
    err = np.linalg.norm(meas.xyz[keep] - predict_points(model, meas.Q[keep], np.array(meas.target)[keep]), axis=1)
    poses = meas.pose[keep]
    return {int(p): float(err[poses == p].mean()) for p in dict.fromkeys(poses.tolist())}


def cross_validate(fit_off: Callable[[Measurements, Monitor], RobotModel],
                   fit_on: Callable[[Measurements, Monitor], RobotModel], meas: Measurements,
                   folds: Sequence[Sequence[int]], *, monitor: Monitor | None = None
                   ) -> tuple[np.ndarray, np.ndarray]:
    """Per-pose mean errors (mm) of the two models, each pose predicted by the fold that held it
    out: (off, on), over the poses some fold could predict."""
    monitor = monitor or Monitor()
    off, on = {}, {}
    for k, test_ids in enumerate(folds):
        sub = monitor.sub(k / len(folds), (k + 1) / len(folds))
        sub.step(0.0, f"deflection terms, cross validation: fold {k + 1} of {len(folds)}")
        held = set(test_ids)
        train = meas.select_poses([p for p in meas.pose_ids if p not in held])
        test = meas.select_poses(list(test_ids))
        known = set(train.target)
        off.update(per_pose_errors(fit_off(train, sub.sub(0.0, 0.5)), test, known))
        on.update(per_pose_errors(fit_on(train, sub.sub(0.5, 1.0)), test, known))
    poses = [p for p in off if p in on]
    return np.array([off[p] for p in poses]), np.array([on[p] for p in poses])


def decide(off: np.ndarray, on: np.ndarray, folds: int, weight: float | None) -> ComplianceChoice:
    """The one-standard-error rule on per-pose errors: keep the terms when their mean error plus its
    standard error is below the geometry-only mean error."""
    n = len(off)
    mean_off, mean_on = float(off.mean()), float(on.mean())
    se = float(on.std(ddof=1) / math.sqrt(n)) if n > 1 else math.inf
    kept = mean_on + se < mean_off
    if kept:
        verdict = (f"The arm bends under its weight: {mean_off - mean_on:.3f} mm of the error is deflection "
                   f"(cross-validated over {n} poses, mean error {mean_off:.3f} mm with geometry only, "
                   f"{mean_on:.3f} mm with the deflection terms); kept.")
    elif mean_on < mean_off:
        verdict = (f"No clear gain with {n} poses: the deflection terms lower the cross-validated mean error "
                   f"only from {mean_off:.3f} to {mean_on:.3f} mm, less than its standard error "
                   f"({se:.3f} mm); geometry only.")
    else:
        verdict = (f"No gain with {n} poses: cross-validated mean error {mean_off:.3f} mm with geometry "
                   f"only, {mean_on:.3f} mm with the deflection terms; geometry only.")
    return ComplianceChoice(AUTO, kept, verdict, n_poses=n, folds=folds, cv_mean_off_mm=mean_off,
                            cv_mean_on_mm=mean_on, standard_error_mm=se, weight=weight if kept else None)


def fixed_choice(mode: str, weight: float | None) -> ComplianceChoice:
    """The choice when it was not left to cross validation."""
    if mode == ON:
        return ComplianceChoice(ON, True, "Deflection terms estimated as asked (not cross-validated).",
                                weight=weight)
    return ComplianceChoice(OFF, False, "Geometry only: deflection terms not asked for.")
