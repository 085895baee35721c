"""Synthetic truth for identification tests and benchmarks (no images, no renderer).

`perturbed_model` draws a "true" robot near a nominal one; `simulate_measurements` gives its
forward kinematics at random configurations plus Gaussian noise, as a `Measurements` object
ready to be written with core.measurement.file.write_measurements.
"""
from __future__ import annotations

from typing import Sequence

import numpy as np
from scipy.spatial.transform import Rotation

from core import transforms as tf
from core.kinematics.jacobian import hayati_joints, predict_points
from core.kinematics.identifiability import random_configurations
from core.kinematics.orientation import predict_rotations
from core.robot.model import RobotModel
from core.measurement.file import Measurements


def perturbed_model(nominal: RobotModel, rng: np.random.Generator | int = 0, *, length_mm: float = 1.0,
                    angle_deg: float = 0.2, base_xyz=(150.0, -80.0, 1400.0), base_rpy_deg=(100.0, 10.0, -30.0),
                    target_mm: float = 1.0, beta: bool = True) -> RobotModel:
    """A 'true' robot: every DH value of `nominal` off by N(0, length_mm) / N(0, angle_deg), Hayati's
    β of parallel axes off by N(0, angle_deg) (when `beta`), the base at `base_xyz`/`base_rpy_deg`
    in the measurement frame and the target offsets off by N(0, target_mm)."""
    rng = np.random.default_rng(rng)
    true = nominal.copy()
    par = set(hayati_joints(nominal)) if beta else set()
    ang = np.deg2rad(angle_deg)
    for i, j in enumerate(true.joints):
        j.theta += rng.normal(0, ang)
        j.d += rng.normal(0, length_mm)
        j.a += rng.normal(0, length_mm)
        j.alpha += rng.normal(0, ang)
        if i in par:
            j.beta += rng.normal(0, ang)
    true.base = tf.pose_to_matrix(base_xyz, np.deg2rad(base_rpy_deg)) @ nominal.base
    true.targets = {k: np.asarray(v, dtype=float) + rng.normal(0, target_mm, 3) for k, v in nominal.targets.items()}
    return true


def simulate_measurements(true: RobotModel, n_poses: int, *, sigma_mm: float = 0.05,
                          targets: Sequence[str] | None = None, rng: np.random.Generator | int = 0,
                          Q: np.ndarray | None = None, with_sigma: bool = False,
                          margin_deg: float = 5.0, orientation_sigma_deg: float | None = None) -> Measurements:
    """Measurements of `true` at `n_poses` random configurations (or the given Q), every pose
    seeing every target, with isotropic Gaussian noise `sigma_mm` per axis; with
    `orientation_sigma_deg`, also the targets' frames (core.kinematics.orientation), turned
    by Gaussian small rotations of that σ about each measurement axis."""
    rng = np.random.default_rng(rng)
    targets = list(true.targets) if targets is None else list(targets)
    if Q is None:
        lo, hi = true.sampling_range(margin_deg)      # margin in deg (revolute) / mm (prismatic)
        Q = rng.uniform(lo, hi, size=(n_poses, true.dof))
    Q = np.atleast_2d(Q)
    Qp = np.repeat(Q, len(targets), axis=0)
    names = [t for _ in range(len(Q)) for t in targets]
    xyz = predict_points(true, Qp, names) + rng.normal(0, sigma_mm, (len(Qp), 3))
    pose = np.repeat(np.arange(len(Q)), len(targets))
    sigma = np.full((len(Qp), 3), sigma_mm) if with_sigma else None
    rotation = rotation_sigma = None
    if orientation_sigma_deg is not None:
        s = np.deg2rad(orientation_sigma_deg)
        R = predict_rotations(true, Qp, names)
        turned = np.array([tf.rot_vec(w) @ r for w, r in zip(rng.normal(0, s, (len(Qp), 3)), R)])
        rotation = Rotation.from_matrix(turned).as_rotvec()
        rotation_sigma = np.full((len(Qp), 3), s)
    return Measurements(pose=pose, target=names, q_file=true.q_to_file(Qp), xyz=xyz, Q=Qp, sigma=sigma,
                        rotation=rotation, rotation_sigma=rotation_sigma)


__all__ = ["perturbed_model", "simulate_measurements", "random_configurations"]
