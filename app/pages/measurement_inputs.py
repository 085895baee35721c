"""What the Marker and Measurement pages both need from the project: the trained marker
(marker.npz beside project.json) and the stereo rectification (the project's stereo.yaml, or
the Stereo step's result not yet saved).

Files in the project folder written by the Marker step:
  marker.npz                  the trained marker (core.marker.training, robocal.trained_marker/1)
  marker_training.png         the image it was trained from (the crop, when cropped)
  marker_verification.json    the last verification of that marker (robocal.marker_verification/1)
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from app.html import number
from core.errors import RoboCalError
from core.marker.training import TrainedMarker
from core.project import Output
from core.stereo.rectification import StereoRectification, load_rectification

MARKER_FILE = "marker.npz"
TRAINING_FILE = "marker_training.png"
VERIFICATION_FILE = "marker_verification.json"
VERIFICATION_FORMAT = "robocal.marker_verification/1"


def marker_file(project) -> Path:
    return Path(project.folder) / MARKER_FILE


def measurement_inputs(project) -> dict[str, Path]:
    """The project files a measurement run locates the marker with, by name: stereo.yaml and
    marker.npz (core.provenance records them beside measurements.csv)."""
    return {path.name: path for path in (project.path(Output.STEREO), marker_file(project))}


def verification_file(project) -> Path:
    return Path(project.folder) / VERIFICATION_FILE


def project_marker(state) -> TrainedMarker | None:
    """The trained marker: the Marker step's output, else the project's marker.npz, else None.
    Raises RoboCalError when marker.npz exists but cannot be read."""
    trained = state.marker
    if trained is not None:
        return trained
    project = state.project
    if project is None or not marker_file(project).is_file():
        return None
    return TrainedMarker.load(marker_file(project))


@dataclass
class StereoSource:
    """Where the stereo rectification comes from, in words for the page."""

    rect: StereoRectification | None
    kind: str            # "file" (stereo.yaml), "result" (calibrated, not saved), "preview" (lab's true rig), ""
    label: str           # one line for the user
    problem: str = ""    # why there is none (or why stereo.yaml cannot be used)


def stereo_source(state) -> StereoSource:
    """The project's stereo.yaml; else the Stereo step's result in memory; else none, with why."""
    project = state.project
    problem = ""
    if project is not None and project.has(Output.STEREO):
        path = project.path(Output.STEREO)
        try:
            rect = load_rectification(path)
        except RoboCalError as exc:
            problem = f"the project's stereo.yaml cannot be used: {exc.message}"
        else:
            sf = rect.calibration
            w, h = sf.image_size
            return StereoSource(rect, "file", f"stereo.yaml: {w}x{h} px, stereo RMS "
                                              f"{number(sf.rms_stereo, 3, 'px')}, baseline {sf.baseline_mm:.1f} mm")
    result = state.stereo
    if result is not None:
        try:
            sf = result.file
            rect = StereoRectification.from_calibration(sf)
        except (RoboCalError, AttributeError) as exc:
            problem = problem or f"the stereo calibration cannot be used: {exc}"
        else:
            return StereoSource(rect, "result", f"stereo calibration of step 2 (not saved yet): stereo RMS "
                                                f"{sf.rms_stereo:.3f} px, baseline {sf.baseline_mm:.1f} mm")
    return StereoSource(None, "", "no stereo calibration", problem or "no stereo calibration yet (step 2)")


def preview_source(lab) -> StereoSource:
    """The virtual lab's TRUE cameras (a preview before calibrating; not a calibration)."""
    return StereoSource(StereoRectification.from_rig(lab.rig), "preview",
                        "PREVIEW: the virtual lab's true cameras (not a calibration; calibrate in step 2 to measure)")


def run_inputs(state, poses) -> tuple[TrainedMarker, StereoSource]:
    """What a measurement run (or a taught pose) locates the marker with: (trained marker, stereo
    source); a RoboCalError saying what is missing (no project or robot, no `poses`, no trained
    marker, no stereo calibration)."""
    if state.project is None or state.robot is None:
        raise RoboCalError("no project or robot yet", hint="Create a project and choose a robot (Setup step).")
    if poses is None:
        raise RoboCalError("no pose list", hint="Select poses in step 4, or load a poses CSV.")
    trained = project_marker(state)
    if trained is None:
        raise RoboCalError("no trained marker", hint="Train the marker in step 3 (Marker).")
    src = stereo_source(state)
    if src.rect is None:
        raise RoboCalError(src.problem or "no stereo calibration",
                           hint="Calibrate the cameras in step 2 and save stereo.yaml.")
    return trained, src
