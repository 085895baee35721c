"""What identification returns: the iterations, the error statistics of a model on measured
points, the validation on poses the fit did not see, the parameter table, and the whole result
(`IdentificationResult`), whose `statistics()` is the one definition of the fit's statistics
written to the calibrated robot file and printed by the command line. Lengths in mm; the table
in file units (mm / deg)."""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Sequence

import numpy as np

from core.files import strict_json
from core.identification.compliance_selection import ComplianceChoice
from core.identification.orientation import OrientationReport
from core.identification.prior import PriorReport
from core.kinematics.identifiability import FIXED_BY_USER, Identifiability, ObservabilityIndices
from core.robot.model import RobotModel


@dataclass
class IterationRecord:
    """One accepted Levenberg–Marquardt iteration (iteration 0 = the start)."""

    iteration: int
    cost: float            # weighted residual sum of squares Σ w·e² (mm² without sigmas)
    rms_mm: float          # RMS of the 3D point errors
    damping: float         # λ used for the step that led here (0 for the start)
    step: float            # norm of the scaled step (mm of predicted change)
    stage: str = "fit"     # "fit", or "huber N" for robust reweighting rounds
    start: bool = False    # the state at the start of a stage (not an iteration)


@dataclass
class ErrorStats:
    """Position errors of a model against measured points (mm)."""

    n: int
    mean_mm: float
    rms_mm: float
    max_mm: float
    median_mm: float
    errors: np.ndarray          # (N,) 3D error norms
    vectors: np.ndarray         # (N, 3) measured − predicted
    pose: np.ndarray            # (N,) pose id of each point
    target: list[str]

    def per_pose(self) -> list[dict]:
        """RMS error of each pose over its targets, in pose order of first appearance."""
        out = []
        for p in dict.fromkeys(self.pose.tolist()):
            sel = self.pose == p
            out.append({"pose": int(p), "n": int(sel.sum()),
                        "error_mm": float(np.sqrt(np.mean(self.errors[sel] ** 2)))})
        return out

    def per_point(self) -> list[dict]:
        return [{"pose": int(self.pose[i]), "target": self.target[i], "error_mm": float(self.errors[i]),
                 "dx": float(self.vectors[i, 0]), "dy": float(self.vectors[i, 1]),
                 "dz": float(self.vectors[i, 2])} for i in range(self.n)]

    def summary(self) -> dict:
        return {"n": self.n, "mean_mm": self.mean_mm, "rms_mm": self.rms_mm, "max_mm": self.max_mm,
                "median_mm": self.median_mm}


def error_stats_from(vectors: np.ndarray, pose, target: Sequence[str]) -> ErrorStats:
    vectors = np.asarray(vectors, dtype=float).reshape(-1, 3)
    err = np.linalg.norm(vectors, axis=1)
    if len(err) == 0:
        return ErrorStats(0, math.nan, math.nan, math.nan, math.nan, err, vectors,
                          np.asarray(pose, dtype=int), list(target))
    return ErrorStats(n=len(err), mean_mm=float(err.mean()), rms_mm=float(np.sqrt(np.mean(err ** 2))),
                      max_mm=float(err.max()), median_mm=float(np.median(err)), errors=err,
                      vectors=vectors, pose=np.asarray(pose, dtype=int), target=list(target))


def merge_stats(parts: Sequence[ErrorStats]) -> ErrorStats:
    return error_stats_from(np.concatenate([p.vectors for p in parts]),
                            np.concatenate([p.pose for p in parts]),
                            [t for p in parts for t in p.target])


@dataclass
class Validation:
    """Errors on measurements the fit did not see (mm)."""

    method: str                       # "holdout" | "kfold"
    before: ErrorStats                # nominal geometry, base registered on the training poses
    after: ErrorStats                 # calibrated on the training poses
    test_poses: list[int]
    fraction: float | None = None
    folds: int | None = None
    seed: int = 0
    fold_rms_mm: list[float] = field(default_factory=list)

    def summary(self) -> dict:
        out = {"method": self.method, "seed": self.seed, "n_test_poses": len(self.test_poses),
               "test_poses": [int(p) for p in self.test_poses],
               "before": self.before.summary(), "after": self.after.summary()}
        if self.fraction is not None:
            out["fraction"] = self.fraction
        if self.folds is not None:
            out["folds"] = self.folds
            out["fold_rms_mm"] = list(self.fold_rms_mm)
        return out


@dataclass
class ParameterRow:
    """One row of the parameter table, in file units (mm / deg).

    For the base, `x, y, z` are the base origin in the measurement frame and `rx, ry, rz` are
    shown as roll, pitch, yaw of the base orientation (Rz·Ry·Rx, as in the robot file), their
    std propagated from the estimated small rotations about the measurement frame axes.
    `std` is None for parameters that were not estimated."""

    name: str
    group: str
    kind: str
    unit: str
    nominal: float
    initial: float
    identified: float
    std: float | None
    identifiable: bool
    status: str
    explanation: str = ""
    partners: tuple[str, ...] = ()
    data_share: float | None = None   # with a prior: the share the measurements determine (0 … 1)

    @property
    def correction(self) -> float:
        d = self.identified - self.nominal
        if self.unit == "deg":
            d = (d + 180.0) % 360.0 - 180.0
        return d

    def as_dict(self) -> dict:
        out = {"name": self.name, "unit": self.unit, "nominal": self.nominal, "identified": self.identified,
               "std": self.std, "identifiable": self.identifiable, "status": self.status,
               "explanation": self.explanation}
        if self.data_share is not None:
            out["data_share"] = self.data_share
        return out


@dataclass
class IdentificationResult:
    """Everything the identification step produces — what the GUI draws and the CLI prints."""

    model: RobotModel                  # calibrated model (its `calibration` section filled)
    nominal: RobotModel                # the input model
    initial: RobotModel                # nominal geometry with the registered base pose
    identifiability: Identifiability
    parameters: list[ParameterRow]     # every parameter of g, in g's order
    estimated: list[str]               # names of the estimated parameters (order of covariance)
    estimate_std: np.ndarray           # their std in internal units (mm / rad)
    covariance: np.ndarray             # (p, p) internal units; base rotations as small angles
    correlation: np.ndarray            # (p, p)
    iterations: list[IterationRecord]  # cost per iteration (all stages)
    converged: bool
    sigma_hat: float                   # a-posteriori std of unit weight (mm per axis w/o sigmas)
    dof: int                           # m − p
    observability: ObservabilityIndices   # of the final column-scaled Φ
    before: ErrorStats                 # fitted points: nominal geometry + registered base
    after: ErrorStats                  # fitted points: calibrated model
    weights: np.ndarray                # (N,) final robust weight of each fitted point (1 without Huber)
    outliers: list[int]                # indices (into the fitted points) flagged as outliers
    validation: Validation | None
    measurements_source: str
    n_poses: int
    n_points: int
    huber: float | None = None
    date: str = ""
    warnings: list[str] = field(default_factory=list)
    weighted: bool = False             # the measurements gave sx, sy, sz: sigma_hat is unitless
    prior: PriorReport | None = None   # the prior toward nominal, when one was asked for
    orientation: OrientationReport | None = None   # when the measured orientations were used
    compliance: ComplianceChoice | None = None     # what was done with the deflection terms, and why
    payload_kg: float | None = None    # the mass mounted during calibration (None: not given)

    @property
    def sigma_hat_text(self) -> str:
        """σ̂ with its meaning: mm per axis, or the factor on the measurements' own sigmas."""
        if self.weighted:
            return f"{self.sigma_hat:.4g} × the measurements' own σ (1 means they were right)"
        return f"{self.sigma_hat:.4g} mm per axis"

    @property
    def n_iterations(self) -> int:
        return sum(1 for r in self.iterations if not r.start)

    @property
    def costs(self) -> list[float]:
        return [r.cost for r in self.iterations]

    @property
    def rank(self) -> int:
        return self.observability.rank

    @property
    def condition_number(self) -> float:
        return self.observability.condition_number

    @property
    def unidentifiable(self) -> list[ParameterRow]:
        return [r for r in self.parameters if not r.identifiable and r.status != FIXED_BY_USER]

    def row(self, name: str) -> ParameterRow:
        return next(r for r in self.parameters if r.name == name)

    def statistics(self) -> dict:
        """The fit's statistics: the one definition behind the calibrated robot file's
        `calibration.statistics` and the command line's --json (each adds its own keys)."""
        out = {
            "n_poses": self.n_poses, "n_points": self.n_points,
            "rms_before_mm": self.before.rms_mm, "rms_after_mm": self.after.rms_mm,
            "mean_after_mm": self.after.mean_mm, "max_after_mm": self.after.max_mm,
            "sigma_hat": self.sigma_hat,
            "iterations": self.n_iterations, "converged": self.converged,
            "cost_per_iteration": strict_json([float(c) for c in self.costs]),
            "rank": self.rank, "n_parameters": len(self.estimated),
            "condition_number": strict_json(self.condition_number),
            "observability": {k: strict_json(v) for k, v in self.observability.as_dict().items()},
        }
        if self.prior is not None:
            out["prior"] = self.prior.summary()
        if self.orientation is not None:
            out["orientation"] = self.orientation.summary()
        if self.compliance is not None:
            out["compliance"] = self.compliance.summary()
        return out

    def calibration_section(self) -> dict:
        """The `calibration` section of the calibrated robot file."""
        stats = {**self.statistics(), "sigma_hat_unit": "1" if self.weighted else "mm", "dof": self.dof,
                 "outliers": len(self.outliers), "huber": self.huber}
        if self.validation is not None:
            stats["validation"] = self.validation.summary()
        return {
            "format": "robocal.calibration/1",
            "date": self.date,
            "payload_kg": self.payload_kg,
            "measurements": Path(self.measurements_source).name if self.measurements_source else "",
            "statistics": stats,
            "parameters": [r.as_dict() for r in self.parameters],
            "unidentifiable": [{"name": r.name, "reason": r.explanation} for r in self.unidentifiable],
            "fixed": [r.name for r in self.parameters if r.status == FIXED_BY_USER],
            "warnings": list(self.warnings),
            "correlation": {"parameters": list(self.estimated),       # of the estimated parameters
                            "matrix": strict_json(np.round(np.asarray(self.correlation, dtype=float), 3).tolist())},
            "covariance": {"parameters": list(self.estimated), "units": "mm and rad",
                           "matrix": [[float(v) for v in row] for row in self.covariance]},
            "tools": self.calibrated_tools(),
        }

    def calibrated_tools(self) -> list[str]:
        """The tools whose targets were measured (and so calibrated)."""
        names = {r.name for r in self.parameters}
        return [tool for tool, targets in self.model.tool_map().items()
                if any(f"{t}.x" in names for t in targets)]

    def summary(self) -> dict:
        """The CLI's --json object."""
        out = {
            **self.statistics(),
            "unidentifiable": [{"name": r.name, "status": r.status, "reason": r.explanation}
                               for r in self.unidentifiable],
            "fixed": [r.name for r in self.parameters if r.status == FIXED_BY_USER],
            "parameters": {r.name: {"value": r.identified, "std": r.std, "unit": r.unit,
                                    "nominal": r.nominal, "identifiable": r.identifiable,
                                    "status": r.status} for r in self.parameters},
            "outliers": [{"pose": int(self.after.pose[i]), "target": self.after.target[i],
                          "error_mm": float(self.after.errors[i])} for i in self.outliers],
            "warnings": list(self.warnings),
            "payload_kg": self.payload_kg,
        }
        if self.validation is not None:
            v = self.validation
            out["holdout"] = v.summary()
            out["holdout_rms_before_mm"] = v.before.rms_mm
            out["holdout_rms_after_mm"] = v.after.rms_mm
        return out
