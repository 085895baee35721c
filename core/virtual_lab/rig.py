"""The default simulated stereo pair of the virtual lab.

Two 1280x1024 cameras with an 8 mm lens-like focal length (f ≈ 1500 px), parallel optical
axes and a 130 mm baseline along +x (the chapter's set-up), mild radial and tangential
distortion, principal points a few pixels off centre, and a slight, seeded, real-world
misalignment of the right camera (≈0.2–0.5° rotation, ~1 mm translation).
OpenCV's convention: X_r = R · X_l + T, so T ≈ (−130, 0, 0) mm.
"""
from __future__ import annotations

import numpy as np

from core import transforms as tf
from core.camera import CameraModel
from core.stereo.rig import StereoRig

WIDTH, HEIGHT = 1280, 1024
FOCAL = 1500.0          # px
BASELINE = 130.0        # mm
DISTORTION = (-0.08, 0.05, 0.0, 0.0, 0.0)   # k1, k2, p1, p2, k3 (p1, p2 drawn small when not given)


def _camera(rng: np.random.Generator, width: int, height: int, focal: float, distortion) -> CameraModel:
    f = focal * (1.0 + rng.uniform(-0.004, 0.004))
    aspect = 1.0 + rng.uniform(-0.0005, 0.0005)
    cx = (width - 1) / 2.0 + rng.uniform(-6.0, 6.0)
    cy = (height - 1) / 2.0 + rng.uniform(-6.0, 6.0)
    K = np.array([[f, 0.0, cx], [0.0, f * aspect, cy], [0.0, 0.0, 1.0]])
    d = np.zeros(5)
    given = np.asarray(distortion, dtype=float).ravel()
    d[:given.size] = given
    # Same lens model on both sides, each lens slightly different; tangential terms small.
    d[0] *= 1.0 + rng.uniform(-0.05, 0.05)
    d[1] *= 1.0 + rng.uniform(-0.05, 0.05)
    d[2] += rng.uniform(-4e-4, 4e-4)
    d[3] += rng.uniform(-4e-4, 4e-4)
    return CameraModel(K, d, width, height)


def default_rig(seed: int | np.random.Generator | None = 0, *, width: int = WIDTH, height: int = HEIGHT,
                focal: float = FOCAL, baseline: float = BASELINE, distortion=DISTORTION,
                misalignment: bool = True) -> StereoRig:
    """The virtual lab's stereo pair (true parameters), seeded.

    `distortion` is (k1, k2, p1, p2, k3); pass zeros for an ideal pinhole pair.
    `misalignment=False` gives exactly parallel cameras with T = (−baseline, 0, 0)."""
    rng = np.random.default_rng(seed)
    left = _camera(rng, width, height, focal, distortion)
    right = _camera(rng, width, height, focal, distortion)
    if not np.any(np.asarray(distortion, dtype=float)):
        left.dist[:] = 0.0
        right.dist[:] = 0.0
    # Right camera pose in the left frame: centre at (+baseline, 0, 0) plus a small error.
    axis = rng.normal(size=3)
    axis /= np.linalg.norm(axis)
    angle = np.deg2rad(rng.uniform(0.2, 0.5))
    offset = rng.normal(size=3)
    offset *= rng.uniform(0.6, 1.2) / np.linalg.norm(offset)
    if not misalignment:
        angle, offset = 0.0, np.zeros(3)
    R_lr = tf.rot_axis(axis, angle)               # right camera axes in the left frame
    C = np.array([baseline, 0.0, 0.0]) + offset      # right optical centre in the left frame
    R = R_lr.T                                       # X_r = R (X_l − C)
    T = -R @ C
    return StereoRig(left, right, R, T)


def rig_to_dict(rig: StereoRig) -> dict:
    """The rig as plain lists (truth files): image size, K1, D1, K2, D2, R, T (mm)."""
    return {
        "image_width": int(rig.left.width),
        "image_height": int(rig.left.height),
        "K1": rig.left.K.tolist(), "D1": rig.left.dist.tolist(),
        "K2": rig.right.K.tolist(), "D2": rig.right.dist.tolist(),
        "R": rig.R.tolist(), "T": rig.T.tolist(),
    }


def right_from_left(rig: StereoRig) -> np.ndarray:
    """4x4 transform taking left-camera coordinates to right-camera coordinates."""
    return tf.make_transform(rig.R, rig.T)
