"""The Marker step's imaging-conditions work, run on worker threads by the Conditions tab: one
marker pair rendered under the chosen light, occlusion and tilt and located, and the
robustness sweep over all three. Points in mm in the left camera frame."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from app.lab import ImagingConditions, RobustnessTable, VirtualLab, marker_pose, pose_tilt, robustness_sweep
from core.marker.location import MarkerLocation, MarkerLocator
from core.task import Monitor


@dataclass
class ConditionsPair:
    conditions: ImagingConditions
    left: np.ndarray
    right: np.ndarray
    location: MarkerLocation
    truth: np.ndarray                 # (3,) mm, the marker's true reference point
    tilt: float                       # deg from facing the cameras

    @property
    def error(self) -> float:
        """Distance (mm) of the located point from the truth; NaN when not located."""
        return float(np.linalg.norm(self.location.point - self.truth)) if self.location.ok else float("nan")


def conditions_pair(lab: VirtualLab, locator: MarkerLocator, conditions: ImagingConditions, index: int, seed: int,
                    *, progress=None, cancelled=None) -> ConditionsPair:
    """The marker plate at a random place (at the conditions' tilt) rendered under the
    conditions' light and occlusion, and located."""
    monitor = Monitor(progress, cancelled)
    monitor.step(0.0, "placing the marker")
    T = marker_pose(lab, np.random.default_rng([seed, 51, index]), conditions)
    monitor.step(0.1, "capturing the pair")
    left, right = lab.render_marker_at(T, np.random.default_rng([seed, 52, index]), conditions=conditions)
    monitor.step(0.3, "locating the marker")
    location = locator.locate(left, right)
    monitor.step(1.0, "done")
    return ConditionsPair(conditions, left, right, location, T[:3, 3].copy(), pose_tilt(lab, T))


def run_sweep(lab: VirtualLab, locator: MarkerLocator, pairs: int, seed: int, side: str, *, progress=None,
              cancelled=None) -> RobustnessTable:
    """The robustness sweep at its default light levels, occlusions and tilts."""
    return robustness_sweep(lab, locator, pairs=pairs, seed=seed, side=side, progress=progress, cancelled=cancelled)
