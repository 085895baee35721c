"""The virtual lab as the wizard and the command line use it.

This is the one module of `app` that imports `core.virtual_lab` (an import-linter contract
keeps it so): pages and commands take the lab's pieces from here.
"""
from __future__ import annotations

from core.measurement.point import located_point
from core.robot.model import RobotModel
import numpy as np

from core.virtual_lab.changes import LabChange, apply_change, parse_change
from core.virtual_lab.conditions import SIDES, ImagingConditions, marker_pose, pose_tilt
from core.virtual_lab.dataset import simulate_dataset
from core.virtual_lab.fixture import VirtualFixture, calibrated_base_truth, place_fixture, render_fixture_pairs
from core.virtual_lab.ideal_measurements import (DEFAULT_POSES, DEFAULT_SIGMA_MM, ideal_lab_measurements, ideal_measure,
                                                 write_ideal_measurements)
from core.virtual_lab.lab import DEFAULT_BOARD, DEFAULT_ROBOT, VirtualLab, lab_options
from core.virtual_lab.marker_comparison import ComparisonResult, candidate_patterns, compare_markers
from core.virtual_lab.robustness import LIGHT, OCCLUSION, TILT, RobustnessTable, robustness_sweep

__all__ = ["DEFAULT_BOARD", "DEFAULT_POSES", "DEFAULT_ROBOT", "DEFAULT_SIGMA_MM", "LIGHT", "OCCLUSION", "SIDES", "TILT",
           "ComparisonResult", "ImagingConditions", "LabChange", "RobustnessTable", "VirtualFixture", "VirtualLab",
           "apply_change", "build_lab", "calibrated_base_truth", "candidate_patterns", "compare_markers",
           "ideal_lab_measurements", "ideal_measure", "image_measure", "lab_options", "marker_pose", "parse_change",
           "place_fixture", "pose_tilt", "render_fixture_pairs", "robustness_sweep", "simulate_dataset",
           "write_ideal_measurements"]


def build_lab(robot: RobotModel | None, seed: int, noise: float) -> VirtualLab:
    """The virtual lab for this robot (same robot, seed and noise: same lab). Takes ~0.3 s
    (its first rendering ~1 s more), so the wizard builds it on a worker thread (`state.labs.when_ready`)."""
    return VirtualLab.create(robot=robot, seed=seed, noise=noise)


def image_measure(lab: VirtualLab, locate, *, seed: int = 0):
    """`measure(q)` for a check through images: the lab renders the pair at q (its true robot
    as it is when called) and `locate(left, right)` (a MarkerLocator's) finds the marker; None
    when it is not found."""
    rng = np.random.default_rng(seed)

    def measure(q):
        left, right = lab.render_marker_pair(q, rng)
        return located_point(locate(left, right))
    return measure
