"""The nine steps of the wizard (DESIGN.md), in order, with what the shell shows for each."""
from __future__ import annotations

from dataclasses import dataclass
from enum import IntEnum


class Step(IntEnum):
    SETUP = 0
    STEREO = 1
    MARKER = 2
    POSES = 3
    MEASUREMENT = 4
    IDENTIFICATION = 5
    EXPORT = 6
    CHECK = 7
    COMPENSATION = 8

    @property
    def number(self) -> int:
        """1-based number shown to the user."""
        return int(self) + 1

    @property
    def slug(self) -> str:
        """Short lowercase name: help file `resources/help/<slug>.html`, screenshot names."""
        return self.name.lower()

    @property
    def info(self) -> "StepInfo":
        return STEP_INFO[self]


@dataclass(frozen=True)
class StepInfo:
    title: str
    summary: str        # one line under the page title
    description: str    # one paragraph: what the step does


STEP_INFO: dict[Step, StepInfo] = {
    Step.SETUP: StepInfo(
        "Setup", "Project folder, robot model, robot connection and cameras.",
        "Choose or create the project folder, pick the robot's nominal DH model (a preset or "
        "a robot.json file), and say how RoboCal reaches the robot and the cameras."),
    Step.STEREO: StepInfo(
        "Stereo calibration", "Checkerboard pairs → intrinsics, distortion, stereo geometry.",
        "You show a checkerboard to both cameras in many positions and tilts. RoboCal detects "
        "the corners in every pair, tells you which parts of the image still lack coverage, and "
        "estimates each camera's focal lengths, principal point and lens distortion, then the "
        "rotation and translation between the two cameras and the rectification that makes "
        "epipolar lines horizontal. It reports the reprojection error per view and the "
        "uncertainty of the result, and writes stereo.yaml."),
    Step.MARKER: StepInfo(
        "Marker", "Train the end-effector marker and check its 3D detection.",
        "You mark the marker on one training image. On every stereo pair RoboCal then finds the "
        "marker area with SIFT features, takes a precise reference point from Canny edges, "
        "finds the same point in the other image by SSD area correlation along the epipolar "
        "line, and triangulates its 3D position. You check the detection live on a few pairs "
        "before measuring."),
    Step.POSES: StepInfo(
        "Pose sequence", "Robot configurations that make the parameters observable.",
        "RoboCal proposes robot configurations inside the joint limits where the marker stays "
        "in view of both cameras, and picks a set that makes every geometric parameter "
        "observable: it shows the condition number of the calibration Jacobian and other "
        "observability indices as poses are added, and writes poses.csv."),
    Step.MEASUREMENT: StepInfo(
        "Measurement", "Drive the robot through the poses and locate the marker in 3D.",
        "The robot moves to each pose of the sequence (Stop is always one key away: Esc). At "
        "each pose both cameras capture an image, the marker is located in 3D, and the joint "
        "values and the marker position are written to measurements.csv. Poses where the "
        "marker is not found are flagged, never silently dropped."),
    Step.IDENTIFICATION: StepInfo(
        "Identification", "Estimate the DH parameters, base and tool from the measurements.",
        "RoboCal estimates the robot's geometric parameters, the base pose in the camera frame "
        "and the marker offset by iterative least squares on the differential model "
        "Δx = J<sub>g</sub>·Δg. It removes parameters the measurements cannot identify, shows the "
        "position errors before and after calibration, the parameter uncertainties, and a "
        "check on poses left out of the fit, and writes calibrated.json."),
    Step.EXPORT: StepInfo(
        "Export", "Parameter files and a report.",
        "Writes the calibrated robot in the formats other tools read (RoboCal JSON, a DH "
        "table as CSV, URDF) and the camera calibration as OpenCV and ROS camera files, plus "
        "a report of the whole calibration with its figures and plots."),
    Step.CHECK: StepInfo(
        "Check", "Is the robot still as calibrated? Check poses, control charts, re-identify.",
        "The robot goes to a few check poses and the cameras measure the marker. Each point is "
        "compared with where the calibrated model puts it, against a limit that comes from the "
        "calibration's own uncertainty, and written to a check log. When the checks leave their "
        "limits, RoboCal says what most likely changed (the tool, the robot base or the cameras, "
        "one joint's zero, or several things) and re-estimates only that from a few proposed "
        "poses, writing a new calibrated.json."),
    Step.COMPENSATION: StepInfo(
        "Compensation", "Make the robot accurate: corrected joints, Go to point, accuracy before/after.",
        "The robot's controller still computes with its nominal model, so a calibration alone does not make "
        "the robot more accurate. Here the calibrated model computes the joints that put the marker where "
        "you ask: type a point (in the robot base frame, the camera frame or on a located fixture) or load a "
        "joint program taught with the nominal model, compare the nominal and the corrected joints and the "
        "predicted error, write the corrected program, and send the robot to a point while the cameras "
        "measure where the marker really is. The accuracy map reaches a grid of targets with both models "
        "and shows how many times more accurate the robot became."),
}
