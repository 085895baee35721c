"""The Identification step's work, without Qt: identify from a measurements file (and, in the
virtual lab, judge the result against the lab's true robot), and write ideal virtual-lab
measurements. The page asks the state for the lab first and hands it in; nothing here builds it.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from app.lab import DEFAULT_POSES, DEFAULT_SIGMA_MM, ideal_lab_measurements, write_ideal_measurements
from core.identification.prior import PriorOptions
from core.identification.model_comparison import TruthAccuracy, identification_accuracy
from core.identification.result import IdentificationResult
from core.identification.solver import identify
from core.measurement.file import Measurements, read_measurements
from core.measurement.synthetic import synthetic_description
from core.robot.model import RobotModel
from core.task import Monitor

TRUTH_POSES = 200          # fresh random visible poses for the accuracy against the true robot


@dataclass
class IdentificationRun:
    """What one run hands back to the page."""

    result: IdentificationResult
    measurements: Measurements
    source: Path
    synthetic: str | None = None          # how synthetic measurements were made, None for measured ones
    accuracy: TruthAccuracy | None = None  # virtual lab only: nominal and calibrated vs the true robot


def run_identification(robot: RobotModel, path: str | Path, *, fixed=(), huber: float | None = None,
                       holdout: float | None = None, kfold: int | None = None, prior: PriorOptions | None = None,
                       seed: int = 0, lab=None, truth_poses: int = TRUTH_POSES, orientation: bool = False,
                       compliance: str = "off", payload_kg: float | None = None,
                       progress=None, cancelled=None) -> IdentificationRun:
    """Read the measurements at `path`, identify `robot`'s parameters, and with a virtual `lab`
    compare the nominal and the calibrated model with its true robot at `truth_poses` fresh
    visible poses (drawn from `seed`). `orientation`: also fit the measured marker orientations.
    `compliance` ("off", "on", "auto") and `payload_kg`: the deflection terms and the payload mounted
    during calibration (core.identification.solver.identify)."""
    monitor = Monitor(progress, cancelled)
    path = Path(path)
    monitor.step(0.0, "reading the measurements")
    meas = read_measurements(path, robot)
    fit = monitor.sub(0.02, 0.85 if lab is not None else 1.0)
    result = identify(robot, meas, fixed=list(fixed), huber=huber, holdout=holdout, kfold=kfold, prior=prior,
                      seed=seed, orientation=orientation, compliance=compliance, payload_kg=payload_kg,
                      progress=fit, cancelled=cancelled)
    accuracy = None
    if lab is not None:
        monitor.step(0.95, "virtual lab: comparing with the true robot")
        Q = lab.random_visible_poses(truth_poses, np.random.default_rng([int(seed), 6]))
        accuracy = identification_accuracy(lab.true_robot, result, Q, [lab.target])
    monitor.step(1.0, "done")
    return IdentificationRun(result=result, measurements=meas, source=path,
                             synthetic=synthetic_description(path), accuracy=accuracy)


def generate_ideal_measurements(path: str | Path, lab, *, n_poses: int = DEFAULT_POSES,
                                sigma_mm: float = DEFAULT_SIGMA_MM, seed: int = 0,
                                progress=None, cancelled=None) -> Path:
    """Ideal measurements of the virtual `lab`'s true robot at `n_poses` random visible poses,
    with Gaussian noise `sigma_mm` (mm), written to `path` marked as synthetic; returns the path."""
    monitor = Monitor(progress, cancelled)
    monitor.step(0.7, "choosing visible poses")
    meas = ideal_lab_measurements(lab, n_poses, sigma_mm=sigma_mm, seed=np.random.default_rng([int(seed), 5]))
    monitor.step(0.9, "writing measurements.csv")
    write_ideal_measurements(meas, path, sigma_mm=sigma_mm)
    monitor.step(1.0, "done")
    return Path(path)
