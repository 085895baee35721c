"""The virtual lab as the wizard and the command line use it.

This is the one module of `app` that imports `core.virtual_lab` (an import-linter contract
keeps it so): pages and commands take the lab's pieces from here.
"""
from __future__ import annotations

from core.robot.model import RobotModel
from core.virtual_lab.dataset import simulate_dataset
from core.virtual_lab.ideal_measurements import (DEFAULT_POSES, DEFAULT_SIGMA_MM, ideal_lab_measurements,
                                                 write_ideal_measurements)
from core.virtual_lab.lab import DEFAULT_BOARD, VirtualLab, lab_options
from core.virtual_lab.marker_comparison import ComparisonResult, candidate_patterns, compare_markers

__all__ = ["DEFAULT_BOARD", "DEFAULT_POSES", "DEFAULT_SIGMA_MM", "ComparisonResult", "VirtualLab", "build_lab",
           "candidate_patterns", "compare_markers", "ideal_lab_measurements", "lab_options", "simulate_dataset",
           "write_ideal_measurements"]


def build_lab(robot: RobotModel | None, seed: int, noise: float) -> VirtualLab:
    """The virtual lab for this robot (same robot, seed and noise: same lab). Takes ~2 s, so
    the wizard builds it on a worker thread (`WizardState.request_lab`)."""
    return VirtualLab.create(robot=robot, seed=seed, noise=noise)
