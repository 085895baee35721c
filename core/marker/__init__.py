"""The end-effector marker: training, detection, correspondence and 3D location.

The chapter's chain, one module per stage:

- core.marker.training     training image -> TrainedMarker (SIFT features, outline, reference point)
- core.marker.detection    SIFT area detection (ratio test, RANSAC homography, region of interest)
- core.marker.edges        Canny on the region, sub-pixel edge lines, reference point = diagonals' intersection
- core.marker.correspondence rectification of the strips needed, SSD criteria function (eq. 26–27), window sweep
- core.marker.location     the stereo pipeline and triangulation (eq. 22–25), tracking mode

This module gathers the public names and loads a marker given on the command line.
"""
from __future__ import annotations

from pathlib import Path

from core.marker.correspondence import Correspondence, WindowSweep, find_disparity, window_sweep
from core.errors import RoboCalError
from core.marker.detection import AreaDetection, DetectionOptions, MarkerDetection, detect_marker, find_marker_area
from core.marker.edges import EdgeOptions, OutlineFit, fit_outline
from core.marker.location import LocatorOptions, MarkerLocation, MarkerLocator, MarkerTracker
from core.marker.training import (DEFAULT_OUTER_SIZE, TrainedMarker, find_outline, train_from_description,
                                  train_marker)

__all__ = [
    "AreaDetection", "Correspondence", "DetectionOptions", "EdgeOptions", "LocatorOptions",
    "MarkerDetection", "MarkerLocation", "MarkerLocator", "MarkerTracker", "OutlineFit",
    "TrainedMarker", "WindowSweep",
    "detect_marker", "find_disparity", "find_marker_area", "find_outline", "fit_outline", "load_marker",
    "train_from_description", "train_marker", "window_sweep",
]


def load_marker(path: str | Path, outer_size: float | None = None) -> tuple[TrainedMarker, bool]:
    """A trained marker from what the user gives, and whether its physical size is known.

    - `.npz`: a trained marker (TrainedMarker.save); its size as trained.
    - `.json`: a marker description (robocal.marker/1): its png and outer corners and size.
    - an image: a training image. A marker description with the same name stem beside it
      (M.png + M.json) whose `image` is this file gives the outer corners and the size;
      otherwise the outline is found automatically and the size is `outer_size`, or the
      default marker's 40 mm when not given (then "not known": the 3D point does not depend
      on it, only the size check is skipped).
    `outer_size` (mm) overrides the size in every case."""
    from core.images import load_gray
    from core.marker.description import MarkerDescription

    path = Path(path)
    if outer_size is not None and not outer_size > 0:
        raise RoboCalError(f"the marker size must be positive, got {outer_size} mm")
    if not path.exists():
        raise RoboCalError("file not found", source=path, hint="Check the path of the marker image.")
    suffix = path.suffix.lower()
    if suffix == ".npz":
        trained = TrainedMarker.load(path)
        if outer_size is not None:
            trained.outer_size = float(outer_size)
        return trained, True
    if suffix == ".json":
        desc = MarkerDescription.load(path)
        trained = train_from_description(desc)
        if outer_size is not None:
            trained.outer_size = float(outer_size)
        return trained, True
    image, why = load_gray(path)
    if image is None:
        raise RoboCalError(f"cannot read the marker image: {why}", source=path,
                           hint="Give a training image (png, jpg), a marker description (.json) or a trained marker (.npz).")
    beside = path.with_suffix(".json")
    corners, size, known = None, DEFAULT_OUTER_SIZE, False
    if beside.is_file():
        try:
            desc = MarkerDescription.load(beside)
        except RoboCalError:
            desc = None
        if desc is not None and Path(desc.image).name == path.name:
            corners, size, known = desc.outer_corners_px, desc.outer_size, True
    if outer_size is not None:
        size, known = float(outer_size), True
    trained = train_marker(image, corners, outer_size=size, name=path.stem, source=str(path))
    return trained, known
