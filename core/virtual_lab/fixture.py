"""A fixture in the virtual lab: a plate with marker points at a known true pose in the robot base frame.

The truth is given in the base frame as the calibration defines it. The first joint's zero angle
and offset cannot be told apart from the base pose, so the calibration keeps them at their nominal
values and its base absorbs their errors: the lab's true base moved by the first joint's true
errors, base · Rz(Δθ_1) · Tz(Δd_1) (`calibrated_base_truth`), is what a perfect calibration finds.

The default fixture is a 220 x 160 mm plate with a marker at each corner (one corner raised 40 mm),
facing the cameras tilted back 25° and turned 15°, its centre 650 mm in front of the left camera.
Each marker plate lies parallel to the fixture plate; its reference point is the marker point.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from core import transforms as tf
from core.fixtures.description import FixtureDescription
from core.virtual_lab.lab import VirtualLab

DEFAULT_POINTS = np.array([[0.0, 0.0, 0.0], [220.0, 0.0, 0.0], [220.0, 160.0, 40.0], [0.0, 160.0, 0.0]])
DEFAULT_NAMES = ["A", "B", "C", "D"]


def calibrated_base_truth(lab: VirtualLab) -> np.ndarray:
    """The true base pose (4x4, base frame → left camera frame, mm) in the calibration's convention
    (see the module)."""
    true, nominal = lab.true_robot.joints[0], lab.nominal_robot.joints[0]
    return lab.true_robot.base @ tf.make_transform(tf.rot_z(true.theta - nominal.theta), [0.0, 0.0, true.d - nominal.d])


@dataclass
class VirtualFixture:
    """`pose` (4x4): fixture frame → robot base frame (the calibration's convention), mm; marker
    points `nominal` (N, 3) mm in the fixture frame, named `names`."""

    pose: np.ndarray
    nominal: np.ndarray
    names: list[str]
    name: str = "virtual fixture"

    def description(self, *, with_positions: bool = True) -> FixtureDescription:
        """The fixture description a technician would write for it (positions left out: the
        three-point frame, for a fixture of three points)."""
        return FixtureDescription(self.name, list(self.names), self.nominal.copy() if with_positions else None)

    def camera_pose(self, lab: VirtualLab) -> np.ndarray:
        """Fixture frame → left camera frame (4x4, mm), true."""
        return calibrated_base_truth(lab) @ self.pose

    def camera_points(self, lab: VirtualLab) -> np.ndarray:
        """True marker reference points (N, 3) mm in the left camera frame."""
        return tf.transform_points(self.camera_pose(lab), self.nominal)

    def plate_poses(self, lab: VirtualLab) -> list[np.ndarray]:
        """Marker plate frame → left camera frame (4x4) of each point: parallel to the fixture."""
        T = self.camera_pose(lab)
        return [T @ tf.make_transform(None, p) for p in self.nominal]


def place_fixture(lab: VirtualLab, *, points=None, names=None, distance: float = 650.0, tilt_deg: float = 25.0,
                  turn_deg: float = 15.0, name: str = "virtual fixture") -> VirtualFixture:
    """A fixture whose marker points (default: `DEFAULT_POINTS`) face the cameras tilted back
    `tilt_deg` and turned `turn_deg`, their centroid `distance` mm in front of the left camera."""
    nominal = DEFAULT_POINTS if points is None else np.asarray(points, dtype=float).reshape(-1, 3)
    names = list(names) if names is not None else (DEFAULT_NAMES[:len(nominal)] if len(nominal) <= 4
                                                   else [f"P{i + 1}" for i in range(len(nominal))])
    facing = tf.rot_y(np.deg2rad(turn_deg)) @ tf.rot_x(np.deg2rad(-tilt_deg)) @ np.diag([1.0, -1.0, -1.0])
    centre = np.array([0.5 * float(lab.rig.right_centre[0]), 0.0, distance])
    camera = tf.make_transform(facing, centre - facing @ nominal.mean(axis=0))
    return VirtualFixture(tf.invert(calibrated_base_truth(lab)) @ camera, nominal.copy(), names, name)


def render_fixture_pairs(lab: VirtualLab, fixture: VirtualFixture, rng=None, *,
                         noise: float | None = None) -> list[tuple[np.ndarray, np.ndarray]]:
    """One stereo pair per marker point: the marker plate at that point, over the room."""
    rng = rng if isinstance(rng, np.random.Generator) else np.random.default_rng(rng)
    return [lab.render_marker_at(pose, rng, noise=noise) for pose in fixture.plate_poses(lab)]
