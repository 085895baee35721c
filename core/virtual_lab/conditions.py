"""Imaging conditions of the virtual lab beyond the geometry: dim light, a partly covered
marker and a steeply tilted marker, so a class can see where the marker method breaks.

- `light`: a gain on the whole scene (1 = the lab's normal light, 0.1 = a tenth of it). The
  sensor's read noise stays the same and its shot noise follows the (dimmer) signal, so the
  signal-to-noise ratio drops as in a real camera, and the image uses only 0 … 255·light grey
  levels (exposure-limited quantisation).
- `occlusion`: a dark band (a cable or a tape strip lying on the plate) covering this fraction
  of the marker's outer square, coming in from `side` ("left", "right", "top", "bottom" of the
  marker as in its training image: a band across the whole plate, hiding one edge of the
  square) or "corner" (a square patch over the top-left corner, hiding part of two edges),
  reaching across the white margin to the plate's edge. It lies on the plate, so both cameras
  see the same part covered.
- `tilt`: the angle (deg) between the marker's normal and the direction from the marker to the
  middle of the two cameras. The robot decides the tilt of a robot pose, so the tilt applies to
  the plate poses drawn by `marker_pose` (the robustness sweep's); light and occlusion apply
  to every marker pair the lab renders with these conditions.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from core import transforms as tf
from core.errors import RoboCalError
from core.virtual_lab.renderer import ImageComposer, PlateTexture

SIDES = ("left", "right", "top", "bottom", "corner")
OCCLUDER_SHADE = 70.0          # grey level of the band under the lab's normal light
NOMINAL_TILT = 30.0            # deg, largest tilt of the plate poses when no tilt is asked for
DEPTH = (400.0, 900.0)         # mm, marker depth of the plate poses (the robot poses' range)


@dataclass(frozen=True)
class ImagingConditions:
    """Light gain (0 < light ≤ 1.5), occluded fraction of the outer square (0 … 0.9) and its
    side, and the tilt of the drawn plate poses (deg; None: up to NOMINAL_TILT at random)."""

    light: float = 1.0
    occlusion: float = 0.0
    side: str = "corner"
    tilt: float | None = None

    def __post_init__(self):
        if not 0.0 < self.light <= 1.5:
            raise RoboCalError(f"light {self.light:g} is outside 0 … 1.5 (a gain on the scene)",
                               field="light", hint="Use 1 for the lab's normal light, 0.1 for a tenth of it.")
        if not 0.0 <= self.occlusion <= 0.9:
            raise RoboCalError(f"occlusion {self.occlusion:g} is outside 0 … 0.9 (a fraction of the marker)",
                               field="occlusion", hint="Use 0.3 to cover 30 % of the marker's outer square.")
        if self.side not in SIDES:
            raise RoboCalError(f"unknown occlusion side {self.side!r}", field="side",
                               hint=f"Use one of {', '.join(SIDES)}.")
        if self.tilt is not None and not 0.0 <= self.tilt <= 85.0:
            raise RoboCalError(f"tilt {self.tilt:g}° is outside 0 … 85°", field="tilt",
                               hint="The tilt is the angle between the marker's normal and the view.")


def occluder_rect(outer_size: float, plate_size, occlusion: float, side: str) -> tuple[float, float, float, float]:
    """The occluder (xmin, xmax, ymin, ymax) in plate mm (reference point at 0, y up as in the
    training image) covering `occlusion` of the outer square of side `outer_size` from `side`,
    out to the plate's edge: a band across the plate's whole width, or a square patch over the
    top-left corner."""
    h, W, H = outer_size / 2.0, plate_size[0] / 2.0, plate_size[1] / 2.0
    if side == "corner":
        a = np.sqrt(occlusion) * outer_size
        return (-W, -h + a, h - a, H)
    reach = -h + occlusion * outer_size              # how far into the square the band comes
    if side == "left":
        return (-W, reach, -H, H)
    if side == "right":
        return (-reach, W, -H, H)
    if side == "top":
        return (-W, W, -reach, H)
    return (-W, W, -H, reach)


def draw_occluder(composer: ImageComposer, marker, world_from_plate: np.ndarray, conditions: ImagingConditions,
                  shade: float = OCCLUDER_SHADE) -> None:
    """The band of `conditions` over the marker plate at `world_from_plate` (4x4), if any.
    Its brightness is the scene's: `finish` applies the light gain."""
    if conditions.occlusion <= 0.0:
        return
    rect = occluder_rect(marker.outer_size, marker.plate_size, conditions.occlusion, conditions.side)
    band = PlateTexture([np.full((4, 4), shade, np.float32)], 1.0, (0.0, 0.0), rect, float(shade))
    composer.draw_plate(band, world_from_plate)


def marker_pose(lab, rng: np.random.Generator, conditions: ImagingConditions = ImagingConditions(), *,
                depth=DEPTH, margin: float = 8.0, max_tries: int = 2000) -> np.ndarray:
    """A marker plate pose (4x4, plate frame -> left camera frame) seen whole by both cameras:
    reference point anywhere in the left view at `depth` mm, turned ±180° about its normal,
    its normal `conditions.tilt` degrees away from the direction to the middle of the cameras
    in a random direction (no tilt given: up to NOMINAL_TILT, uniform over the cap).

    The numbers drawn do not depend on the tilt: a generator in the same state gives the same
    place, turn and tilt direction at every tilt whose first draw keeps the marker in view (a
    paired comparison)."""
    cam = lab.rig.left
    middle = 0.5 * lab.rig.right_centre
    corners = lab.marker.plate_corners()
    for _ in range(max_tries):
        uv = np.array([rng.uniform(0, cam.width), rng.uniform(0, cam.height)])
        z = rng.uniform(*depth)
        phi = rng.uniform(0.0, 2 * np.pi)
        cos_random = rng.uniform(np.cos(np.deg2rad(NOMINAL_TILT)), 1.0)
        roll = rng.uniform(-np.pi, np.pi)
        tilt = np.arccos(cos_random) if conditions.tilt is None else np.deg2rad(conditions.tilt)
        xy = cam.pixels_to_normalized(uv[None])[0]
        P = np.array([xy[0], xy[1], 1.0]) * z
        facing = (middle - P) / np.linalg.norm(middle - P)
        x = np.cross([0.0, 1.0, 0.0], facing)
        x /= np.linalg.norm(x)
        R0 = np.column_stack([x, np.cross(facing, x), facing])
        R = R0 @ tf.rot_axis(np.array([np.cos(phi), np.sin(phi), 0.0]), tilt) @ tf.rot_z(roll)
        T = tf.make_transform(R, P)
        C = tf.transform_points(T, corners)
        if not cam.in_image(cam.project(C), margin).all():
            continue
        if not lab.rig.right.in_image(lab.rig.right.project(lab.rig.to_right(C)), margin).all():
            continue
        return T
    raise RoboCalError("no marker pose at this tilt keeps the marker in view of both cameras",
                       field="tilt", hint="Use a smaller tilt or a nearer depth range.")


def pose_tilt(lab, T: np.ndarray) -> float:
    """Degrees between the plate normal and the direction to the middle of the cameras."""
    d = 0.5 * lab.rig.right_centre - T[:3, 3]
    return float(np.degrees(np.arccos(np.clip(T[:3, 2] @ d / np.linalg.norm(d), -1.0, 1.0))))
