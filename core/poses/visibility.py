"""Which robot configurations show the end-effector marker well to both cameras (vectorised).

The marker plate lies in the tool frame's x-y plane, centred on a target point of the robot
(default "marker"), facing along the tool z axis. A configuration is visible when
  - the marker centre and the 4 plate corners project inside both images, `margin` px from
    the border (and lie in front of both cameras, inside the lens model's valid field),
  - the plate faces both cameras: the angle between the tool z axis and the direction from
    the marker to each optical centre is at most `max_angle_deg`,
  - the marker centre's depth (z in each camera frame) lies in [min_depth, max_depth] mm.
Occlusion by the robot's own links is not modelled.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from core.camera import CameraModel
from core.robot.model import RobotModel
from core.stereo.rig import StereoRig

DEFAULT_MARGIN = 20.0          # px
DEFAULT_MAX_ANGLE = 60.0       # deg
DEFAULT_DEPTH = (350.0, 1000.0)  # mm


@dataclass
class Visibility:
    """Per configuration (N,): the overall verdict and each criterion, for explanations."""

    visible: np.ndarray
    in_left: np.ndarray
    in_right: np.ndarray
    facing: np.ndarray
    depth_ok: np.ndarray
    angle_left: np.ndarray     # deg between plate normal and the direction to the left camera
    angle_right: np.ndarray
    depth: np.ndarray          # mm, marker centre z in the left camera frame
    centre: np.ndarray         # (N, 3) marker centre, world (left camera) frame, mm


def _valid_radius(camera: CameraModel) -> float:
    """Largest normalised radius of the image corners (undistorted), with 20 % headroom:
    beyond it the distortion polynomial is not trusted."""
    w, h = camera.width, camera.height
    corners = np.array([[-0.5, -0.5], [w - 0.5, -0.5], [w - 0.5, h - 0.5], [-0.5, h - 0.5]])
    return 1.2 * float(np.linalg.norm(camera.pixels_to_normalized(corners), axis=1).max())


def _in_image(camera: CameraModel, P: np.ndarray, margin: float) -> np.ndarray:
    """P (N, k, 3) in the camera frame -> (N,) all k points in front and inside the image."""
    z = P[..., 2]
    front = np.all(z > 1.0, axis=-1)
    zs = np.where(z > 1.0, z, 1.0)
    xy = P[..., :2] / zs[..., None]
    inside_field = np.all(np.linalg.norm(xy, axis=-1) < _valid_radius(camera), axis=-1)
    uv = camera.normalized_to_pixels(xy)
    inside = np.all(camera.in_image(uv, margin), axis=-1)
    return front & inside_field & inside


def plate_points(T_tool: np.ndarray, target: np.ndarray, plate_size) -> np.ndarray:
    """Marker centre and plate corners in the world frame: T_tool (N, 4, 4) -> (N, 5, 3)."""
    w, h = (float(plate_size), float(plate_size)) if np.isscalar(plate_size) else map(float, plate_size)
    local = np.array([[0, 0, 0], [-w / 2, -h / 2, 0], [w / 2, -h / 2, 0], [w / 2, h / 2, 0], [-w / 2, h / 2, 0]])
    local = local + np.asarray(target, dtype=float)
    R, t = T_tool[:, :3, :3], T_tool[:, :3, 3]
    return np.einsum("nij,kj->nki", R, local) + t[:, None, :]


def marker_visibility(Q, robot: RobotModel, rig: StereoRig, plate_size, *, target: str = "marker",
                      margin: float = DEFAULT_MARGIN, max_angle_deg: float = DEFAULT_MAX_ANGLE,
                      min_depth: float = DEFAULT_DEPTH[0], max_depth: float = DEFAULT_DEPTH[1]) -> Visibility:
    """Visibility of the marker for joint configurations Q (N, n) (internal units: rad / mm).

    `plate_size` is the plate side (mm) or (width, height); the world frame of `robot` must
    be the left camera frame."""
    Q = np.atleast_2d(np.asarray(Q, dtype=float))
    T = robot.fk_many(Q)
    pts = plate_points(T, robot.targets[target], plate_size)          # (N, 5, 3) left frame
    centre = pts[:, 0]
    normal = T[:, :3, 2]
    pts_r = pts @ rig.R.T + rig.T
    in_left = _in_image(rig.left, pts, margin)
    in_right = _in_image(rig.right, pts_r, margin)

    def angle_to(c):
        d = c[None, :] - centre
        cosang = np.einsum("ni,ni->n", normal, d) / np.maximum(np.linalg.norm(d, axis=1), 1e-9)
        return np.rad2deg(np.arccos(np.clip(cosang, -1.0, 1.0)))

    angle_left = angle_to(np.zeros(3))
    angle_right = angle_to(rig.right_centre)
    facing = (angle_left <= max_angle_deg) & (angle_right <= max_angle_deg)
    depth = centre[:, 2]
    depth_r = pts_r[:, 0, 2]
    depth_ok = ((depth >= min_depth) & (depth <= max_depth) & (depth_r >= min_depth) & (depth_r <= max_depth))
    visible = in_left & in_right & facing & depth_ok
    return Visibility(visible, in_left, in_right, facing, depth_ok, angle_left, angle_right, depth, centre)


def visible_mask(Q, robot: RobotModel, rig: StereoRig, plate_size, **options) -> np.ndarray:
    """(N,) bool: `marker_visibility(...).visible`."""
    return marker_visibility(Q, robot, rig, plate_size, **options).visible
