"""Shared scenes for the marker tests: one virtual lab, its trained marker, poses and composites."""
from __future__ import annotations

from functools import lru_cache

import numpy as np

from core import transforms as tf
from core.marker.training import TrainedMarker, train_marker
from core.virtual_lab.lab import VirtualLab
from tests.session_cache import lab_copy


@lru_cache(maxsize=1)
def lab() -> VirtualLab:
    return lab_copy(seed=0)


@lru_cache(maxsize=1)
def trained() -> TrainedMarker:
    L = lab()
    return train_marker(L.render_training_image(), L.training_geometry()["outer_corners_px"])


def pose_at(u: float, v: float, z: float, rot: float = 0.0, tilt: float = 0.0) -> np.ndarray:
    """Marker plate pose (4x4, left camera frame) with its centre seen at left pixel (u, v),
    depth z mm, rotated `rot` degrees in its plane and tilted `tilt` degrees about its x axis."""
    cam = lab().rig.left
    xy = cam.pixels_to_normalized(np.array([[u, v]], float))[0]
    P = np.array([xy[0], xy[1], 1.0]) * z
    R = np.diag([1.0, -1.0, -1.0]) @ tf.rot_x(np.deg2rad(tilt)) @ tf.rot_z(np.deg2rad(rot))
    return tf.make_transform(R, P)


def compose(left_poses, right_poses, seed: int = 0, noise: float = 0.5, flat: bool = False
            ) -> tuple[np.ndarray, np.ndarray]:
    """A stereo pair over the room with the marker drawn at the given poses in each image
    (`flat`: without vignetting, so that equal objects look equal anywhere in the image)."""
    L = lab()
    left, right = L._composers()
    for composer, poses in ((left, left_poses), (right, right_poses)):
        for T in poses:
            composer.draw_plate(L.marker_texture, T)
    rng = np.random.default_rng(seed)
    kw = {"vignetting_strength": 0.0} if flat else {}
    return left.finish(rng, noise, **kw), right.finish(rng, noise, **kw)


def true_left(T: np.ndarray) -> np.ndarray:
    return lab().rig.left.project(T[:3, 3][None])[0]
