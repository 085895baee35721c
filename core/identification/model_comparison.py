"""How far apart two robot models put the same targets: the "real accuracy" of a model.

A measured point tells how well a model fits the measurements; what a user wants to know is
how well it predicts where the tool really goes. In the virtual lab the true robot is known,
so a calibrated model can be judged directly against it on configurations that were never
measured:

    comparison = compare_models(lab.true_robot, result.model, Q)     # Q (N, n), rad / mm
    comparison.rms_mm, comparison.max_mm

`accuracy_against_truth` does it for the nominal (base registered) and the calibrated model at
once. A calibrated model lives in the *measured* camera frame, which differs from the true
camera frame by the stereo calibration's own small error (e.g. a principal point off by half a
pixel tilts the frame); that offset does not make the robot any less accurate, so the
comparison is made after the best rigid alignment of the two models' point sets (`align=True`,
the default there), and the unaligned figure is kept as `raw_rms_mm`. Errors are 3D distances
in mm.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Iterable, Sequence

import numpy as np

from core.errors import RoboCalError
from core.robot.model import RobotModel
from core.transforms import kabsch, transform_points


@dataclass
class ModelComparison:
    """Position differences |p_candidate(q) − p_reference(q)| of the targets (mm)."""

    n: int                     # number of compared points (configurations × targets)
    mean_mm: float
    rms_mm: float
    max_mm: float
    median_mm: float
    errors: np.ndarray         # (N,) 3D distances, configuration-major, targets in `targets` order
    targets: list[str]
    n_configurations: int
    aligned: bool = False      # compared after the best rigid alignment of the candidate's points
    raw_rms_mm: float = math.nan   # RMS before that alignment (equal to rms_mm when not aligned)

    def summary(self) -> dict:
        return {"n": self.n, "n_configurations": self.n_configurations, "targets": list(self.targets),
                "mean_mm": self.mean_mm, "rms_mm": self.rms_mm, "max_mm": self.max_mm,
                "median_mm": self.median_mm, "aligned": self.aligned, "raw_rms_mm": self.raw_rms_mm}


def common_targets(a: RobotModel, b: RobotModel) -> list[str]:
    """Targets defined in both models, in `a`'s order."""
    return [t for t in a.targets if t in b.targets]


def compare_models(reference: RobotModel, candidate: RobotModel, Q, targets: Iterable[str] | None = None,
                   *, align: bool = False) -> ModelComparison:
    """Distances between the target positions of `candidate` and `reference` at the joint
    configurations Q ((N, n) or (n,), internal units: rad for revolute, mm for prismatic
    joints). `targets` defaults to every target the two models share. With `align`, the
    candidate's points are first moved by the rigid transform that best fits them onto the
    reference's (frame offsets removed, geometry compared)."""
    if reference.dof != candidate.dof:
        raise RoboCalError(f"the models have different joint counts ({reference.dof} and {candidate.dof})",
                           hint="Compare models of the same robot.")
    names = common_targets(reference, candidate) if targets is None else list(targets)
    if not names:
        raise RoboCalError("the two models share no target to compare",
                           hint="Give both models the same target (e.g. 'marker').")
    for t in names:
        for label, model in (("reference", reference), ("candidate", candidate)):
            if t not in model.targets:
                raise RoboCalError(f"target '{t}' is not defined in the {label} model '{model.name}'",
                                   hint="Compare targets both models define.")
    Q = np.atleast_2d(np.asarray(Q, dtype=float))
    if Q.shape[1] != reference.dof:
        raise RoboCalError(f"expected {reference.dof} joint values per configuration, got {Q.shape[1]}")
    if len(Q) == 0:
        raise RoboCalError("no configurations to compare the models at")
    ref = np.stack([reference.target_positions(Q, t) for t in names], axis=1).reshape(-1, 3)
    cand = np.stack([candidate.target_positions(Q, t) for t in names], axis=1).reshape(-1, 3)
    raw_rms = float(math.sqrt(np.mean(np.sum((cand - ref) ** 2, axis=1))))
    if align and len(ref) >= 3:
        cand = transform_points(kabsch(cand, ref), cand)
    err = np.linalg.norm(cand - ref, axis=1)
    return ModelComparison(n=len(err), mean_mm=float(err.mean()), rms_mm=float(math.sqrt(np.mean(err ** 2))),
                           max_mm=float(err.max()), median_mm=float(np.median(err)), errors=err,
                           targets=names, n_configurations=len(Q), aligned=bool(align and len(ref) >= 3),
                           raw_rms_mm=raw_rms)


@dataclass
class TruthAccuracy:
    """Nominal and calibrated model against the true robot on the same configurations."""

    nominal: ModelComparison
    calibrated: ModelComparison
    n_configurations: int

    @property
    def improvement(self) -> float:
        """RMS before / RMS after (how many times more accurate)."""
        return self.nominal.rms_mm / self.calibrated.rms_mm if self.calibrated.rms_mm > 0 else math.inf

    def summary(self) -> dict:
        return {"n_configurations": self.n_configurations, "nominal": self.nominal.summary(),
                "calibrated": self.calibrated.summary()}


def accuracy_against_truth(truth: RobotModel, nominal: RobotModel, calibrated: RobotModel, Q,
                           targets: Sequence[str] | None = None, *, align: bool = True) -> TruthAccuracy:
    """`compare_models` of the nominal and of the calibrated model against `truth` at Q.
    `nominal` should carry a base registered in the measurement frame (the identification
    result's `initial` model), or its errors are mostly the unknown base pose."""
    names = list(targets) if targets is not None else [t for t in common_targets(truth, calibrated)
                                                        if t in nominal.targets]
    before = compare_models(truth, nominal, Q, names, align=align)
    after = compare_models(truth, calibrated, Q, names, align=align)
    return TruthAccuracy(nominal=before, calibrated=after, n_configurations=before.n_configurations)


def identification_accuracy(truth: RobotModel, result, Q, targets: Sequence[str] | None = None) -> TruthAccuracy:
    """What an identification gained against the true robot at configurations Q ((N, n), rad /
    mm) it never measured: the nominal model with its base registered (`result.initial`) and
    the calibrated model (`result.model`) of a core.identification.result.IdentificationResult,
    each after the best rigid alignment (mm)."""
    return accuracy_against_truth(truth, result.initial, result.model, Q, targets)
