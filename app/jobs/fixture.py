"""Locating a fixture for the Check page: from the virtual lab's fixture or from a folder of image
pairs, through the project's calibration; writes the fixture pose (JSON + URDF) beside it."""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from core.fixtures.base import read_base_transform
from core.fixtures.description import read_fixture_description, write_fixture_description
from core.fixtures.file import write_fixture_pose
from core.fixtures.frame import pose_error
from core.fixtures.run import FixtureResult, locate_fixture
from core.marker.location import LocatorOptions, MarkerLocator
from core.task import Monitor

POSE_FILE = "fixture_pose.json"
URDF_FILE = "fixture.urdf"
LAB_DESCRIPTION = "lab_fixture.json"


@dataclass
class FixtureRun:
    """The located fixture, the files written and, on the virtual lab, the error against the true
    pose (ξ: mm and rad, core.fixtures.frame.pose_error)."""

    result: FixtureResult
    pose_path: Path
    urdf_path: Path
    true_error: np.ndarray | None = None


def _write(result: FixtureResult, folder: Path, sources: dict) -> tuple[Path, Path]:
    pose, urdf = Path(folder) / POSE_FILE, Path(folder) / URDF_FILE
    write_fixture_pose(pose, result.frame, name=result.description.name, sources=sources, urdf=urdf)
    return pose, urdf


def locate_on_lab(calibrated, trained, rect, folder, *, lab, seed: int = 0, progress=None,
                  cancelled=None) -> FixtureRun:
    """The lab's fixture (core.virtual_lab.fixture, default placement): its description written to
    `folder`/lab_fixture.json, its pairs rendered and located, the pose written."""
    from app.lab import place_fixture, render_fixture_pairs

    monitor = Monitor(progress, cancelled)
    fixture = place_fixture(lab)
    description = fixture.description()
    description.source = str(write_fixture_description(Path(folder) / LAB_DESCRIPTION, description))
    base = read_base_transform(calibrated)
    monitor.step(0.0, "rendering the fixture's image pairs")
    pairs = render_fixture_pairs(lab, fixture, np.random.default_rng(seed))
    locator = MarkerLocator(trained, rect, LocatorOptions())
    result = locate_fixture(pairs, locator, base, description, progress=monitor.sub(0.2, 0.95))
    pose, urdf = _write(result, folder, {"calibration": str(calibrated), "robot": base.robot,
                                         "fixture_description": description.source, "images": "virtual lab"})
    monitor.step(1.0, "written")
    return FixtureRun(result, pose, urdf, pose_error(result.frame.matrix, fixture.pose))


def locate_from_folder(calibrated, trained, rect, description_path, pairs_folder, folder, *, progress=None,
                       cancelled=None) -> FixtureRun:
    """The fixture of `description_path` from `pairs_folder` (left/<name>.png, right/<name>.png)."""
    from core.fixtures.pairs import fixture_image_loaders, fixture_pair_files

    description = read_fixture_description(description_path)
    base = read_base_transform(calibrated)
    files = fixture_pair_files([str(pairs_folder)], description.names)
    pairs = fixture_image_loaders(files, rect.image_size)
    result = locate_fixture(pairs, MarkerLocator(trained, rect, LocatorOptions()), base, description,
                            progress=Monitor(progress, cancelled).sub(0.0, 0.95))
    pose, urdf = _write(result, folder, {
        "calibration": str(calibrated), "robot": base.robot, "fixture_description": str(description_path),
        "images": [{"point": n, "left": str(a), "right": str(b)} for n, (a, b) in zip(description.names, files)]})
    return FixtureRun(result, pose, urdf)
