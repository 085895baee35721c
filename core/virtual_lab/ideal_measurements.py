"""Ideal virtual-lab measurements for teaching: the lab's TRUE robot at random visible poses
plus Gaussian noise, with no images, no marker detection and no triangulation.

They let the Identification step be shown before (or without) the Measurement step. The file
is an ordinary measurements.csv with one extra comment line saying it is synthetic, so every
screen and report can label it as such:

    meas = ideal_lab_measurements(lab, 50, sigma_mm=0.05, seed=0)
    write_ideal_measurements(meas, project.path(Output.MEASUREMENTS), sigma_mm=0.05)
    core.measurement.synthetic.is_synthetic(project.path(Output.MEASUREMENTS))   # True
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from core.measurement.file import Measurements
from core.measurement.synthetic import write_synthetic_measurements
from core.virtual_lab.synthetic import simulate_measurements

DEFAULT_POSES = 50
DEFAULT_SIGMA_MM = 0.05


def ideal_lab_measurements(lab, n_poses: int = DEFAULT_POSES, *, sigma_mm: float = DEFAULT_SIGMA_MM,
                           seed: int | np.random.Generator = 0) -> Measurements:
    """The lab's true robot at `n_poses` random configurations where both cameras see the
    marker, with isotropic Gaussian noise `sigma_mm` (mm per axis) on the marker position."""
    rng = np.random.default_rng(seed)
    Q = lab.random_visible_poses(n_poses, rng)
    return simulate_measurements(lab.true_robot, len(Q), sigma_mm=sigma_mm, Q=Q, targets=[lab.target], rng=rng)


def synthetic_note(sigma_mm: float, n_poses: int) -> str:
    return (f"ideal virtual-lab measurements (true robot at {n_poses} random visible poses "
            f"+ Gaussian noise sigma = {sigma_mm:g} mm per axis; no images)")


def write_ideal_measurements(meas: Measurements, path: str | Path, *, sigma_mm: float = DEFAULT_SIGMA_MM) -> Path:
    """Write `meas` as measurements.csv (atomically), marked synthetic."""
    return write_synthetic_measurements(meas, path, synthetic_note(sigma_mm, meas.n_poses))


def ideal_measure(lab, *, sigma_mm: float = DEFAULT_SIGMA_MM, seed: int | np.random.Generator = 0):
    """`measure(q)` for a check (core.monitoring.check): the lab's true marker position at q
    (rad / mm) — as the lab's true robot is when called, changes included — plus isotropic
    Gaussian noise `sigma_mm` (mm per axis)."""
    rng = np.random.default_rng(seed)

    def measure(q):
        return lab.marker_position(q) + rng.normal(0.0, sigma_mm, 3)
    return measure
