"""How far apart two robot models put the same targets: the "real accuracy" of a model.

A measured point tells how well a model fits the measurements; what a user wants to know is
how well it predicts where the tool really goes. In the virtual lab the true robot is known,
so a calibrated model can be judged directly against it on configurations that were never
measured:

    comparison = compare_models(lab.true_robot, result.model, Q)     # Q (N, n), rad / mm
    comparison.rms_mm, comparison.max_mm

`accuracy_against_truth` does it for the nominal (base registered) and the calibrated model at
once. Both models must express their base in the same frame (here: the measurement frame =
the left camera frame). Errors are 3D distances in mm.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Iterable, Sequence

import numpy as np

from core.errors import RoboCalError
from core.kinematics import RobotModel


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

    def summary(self) -> dict:
        return {"n": self.n, "n_configurations": self.n_configurations, "targets": list(self.targets),
                "mean_mm": self.mean_mm, "rms_mm": self.rms_mm, "max_mm": self.max_mm,
                "median_mm": self.median_mm}


def common_targets(a: RobotModel, b: RobotModel) -> list[str]:
    """Targets defined in both models, in `a`'s order."""
    return [t for t in a.targets if t in b.targets]


def compare_models(reference: RobotModel, candidate: RobotModel, Q, targets: Iterable[str] | None = None
                   ) -> ModelComparison:
    """Distances between the target positions of `candidate` and `reference` at the joint
    configurations Q ((N, n) or (n,), internal units: rad for revolute, mm for prismatic
    joints). `targets` defaults to every target the two models share."""
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
    diff = np.stack([candidate.target_positions(Q, t) - reference.target_positions(Q, t) for t in names],
                    axis=1).reshape(-1, 3)
    err = np.linalg.norm(diff, axis=1)
    return ModelComparison(n=len(err), mean_mm=float(err.mean()), rms_mm=float(math.sqrt(np.mean(err ** 2))),
                           max_mm=float(err.max()), median_mm=float(np.median(err)), errors=err,
                           targets=names, n_configurations=len(Q))


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
                           targets: Sequence[str] | None = None) -> TruthAccuracy:
    """`compare_models` of the nominal and of the calibrated model against `truth` at Q.
    `nominal` should carry a base registered in the measurement frame (the identification
    result's `initial` model), or its errors are mostly the unknown base pose."""
    names = list(targets) if targets is not None else [t for t in common_targets(truth, calibrated)
                                                        if t in nominal.targets]
    before = compare_models(truth, nominal, Q, names)
    after = compare_models(truth, calibrated, Q, names)
    return TruthAccuracy(nominal=before, calibrated=after, n_configurations=before.n_configurations)
