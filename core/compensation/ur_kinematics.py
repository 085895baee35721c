"""A calibrated Universal Robots model as the kinematics calibration YAML of ROS `ur_description`
and `ur_robot_driver` (`kinematics: {shoulder, upper_arm, forearm, wrist_1, wrist_2, wrist_3}`,
each `{x, y, z, roll, pitch, yaw}` in metres and radians, plus `hash`).

How ur_description builds its chain from that file (UniversalRobots/Universal_Robots_ROS2_Description
at commit 2221ec0f720fb1af99339eb891639b499b62f1da, urdf/ur_macro.xacro and urdf/inc/ur_common.xacro):
    base_link ─(fixed, rpy 0 0 π)→ base_link_inertia
    ─(shoulder_pan_joint: origin = shoulder, axis z)→ shoulder_link
    ─(shoulder_lift_joint: origin = upper_arm)→ upper_arm_link ─(elbow_joint: forearm)→ forearm_link
    ─(wrist_1_joint: wrist_1)→ ─(wrist_2_joint: wrist_2)→ ─(wrist_3_joint: wrist_3)→ wrist_3_link
    ─(fixed, rpy 0 −π/2 −π/2)→ flange ─(fixed, rpy π/2 0 π/2)→ tool0   (these two cancel: tool0
    has wrist_3_link's pose)
where each joint's child frame is  parent · Tr(x, y, z) · Rz(yaw)·Ry(pitch)·Rx(roll) · Rz(q).

From RoboCal's model (A_i = Rz(θ_i + q_i)·Tz(d_i)·Tx(a_i)·Rx(α_i)·Ry(β_i)): let link_i be DH
frame i−1 turned by Rz(θ_i + q_i)·Tz(d_i), so that joint i turns link_i about its z axis. Then
    origin(shoulder) = Rz(θ_1)·Tz(d_1)                        (base_link_inertia = DH frame 0)
    origin(joint i)  = Tx(a_(i−1))·Rx(α_(i−1))·Ry(β_(i−1))·Rz(θ_i)·Tz(d_i),   i = 2 … 6
exactly (the published UR5 DH gives ur_description's default UR5 file: upper_arm roll π/2,
forearm x −0.425, wrist_1 x −0.39225 z 0.10915, …). What follows the last joint,
Tx(a_6)·Rx(α_6)·Ry(β_6), has no place in the file: it is returned as `flange_offset` (tool0 →
RoboCal's DH frame 6, mm), to add to the robot's TCP (zero for an uncalibrated UR). The base
(DH frame 0 in the camera frame) is not part of the file either: ur_description's base_link is
DH frame 0 turned by π about z.

`hash` identifies the calibration (ur_robot_driver compares it with the controller's own
calibration checksum and warns when they differ; this file's comes from RoboCal, so the driver
warns, as after any calibration made outside the controller).
"""
from __future__ import annotations

import hashlib
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from core import transforms as tf
from core.errors import RoboCalError
from core.files import atomic_write_text
from core.robot.model import RobotModel

ENTRIES = ("shoulder", "upper_arm", "forearm", "wrist_1", "wrist_2", "wrist_3")
SOURCE_COMMIT = "UniversalRobots/Universal_Robots_ROS2_Description@2221ec0f720fb1af99339eb891639b499b62f1da"


@dataclass
class URKinematics:
    """`origins`: per entry the joint origin (4x4, mm); `flange_offset` (4x4, mm): tool0 →
    RoboCal's DH frame 6; `hash` the file's calibration hash."""

    origins: dict[str, np.ndarray]
    flange_offset: np.ndarray
    hash: str


def _rx(a):
    return tf.make_transform(tf.rot_x(a))


def _ry(a):
    return tf.make_transform(tf.rot_y(a))


def _rz(a):
    return tf.make_transform(tf.rot_z(a))


def _t(x=0.0, y=0.0, z=0.0):
    return tf.make_transform(None, [x, y, z])


def ur_kinematics(model: RobotModel) -> URKinematics:
    """The ur_description joint origins of a (calibrated) six-joint UR model. RoboCalError for a
    robot that is not six revolute joints."""
    ur_alpha = np.deg2rad([90.0, 0.0, 0.0, 90.0, -90.0, 0.0])
    if model.dof != 6 or not model.revolute_mask().all() or \
            np.any(np.abs(np.array([j.alpha for j in model.joints]) - ur_alpha) > np.deg2rad(5.0)):
        raise RoboCalError(f"the robot '{model.name}' is not a Universal Robots arm (six revolute joints, "
                           "DH α 90°, 0, 0, 90°, −90°, 0)",
                           hint="The UR kinematics file is for UR3, UR5, UR10 and their e-Series.")
    J = model.joints
    origins = {ENTRIES[0]: _rz(J[0].theta) @ _t(z=J[0].d)}
    for i in range(1, 6):
        p = J[i - 1]
        origins[ENTRIES[i]] = (_t(x=p.a) @ _rx(p.alpha) @ _ry(p.beta) @ _rz(J[i].theta) @ _t(z=J[i].d))
    last = J[5]
    flange = _t(x=last.a) @ _rx(last.alpha) @ _ry(last.beta)
    digest = hashlib.sha1(np.concatenate([T.ravel() for T in origins.values()]).round(12).tobytes()).hexdigest()
    return URKinematics(origins, flange, f"calib_robocal_{digest[:16]}")


def _num(v: float) -> str:
    v = float(v)
    return "0" if v == 0 else repr(v)


def ur_kinematics_yaml(model: RobotModel, *, source: str = "") -> str:
    """The text of the kinematics YAML (metres, radians)."""
    k = ur_kinematics(model)
    off_xyz, off_rpy = tf.matrix_to_pose(k.flange_offset)
    lines = [f"# Kinematics of '{model.name}' from RoboCal" + (f" ({source})" if source else "")
             + " for ur_description / ur_robot_driver (metres, radians).",
             f"# Joint origins as {SOURCE_COMMIT} urdf/ur_macro.xacro builds them.",
             "# After the last joint the calibrated flange lies at, in tool0 (add it to the TCP): "
             f"xyz [{', '.join(f'{v:.9f}' for v in off_xyz)}] mm, "
             f"rpy [{', '.join(f'{v:.12f}' for v in np.rad2deg(off_rpy))}] deg.",
             "kinematics:"]
    for name in ENTRIES:
        xyz, rpy = tf.matrix_to_pose(k.origins[name])
        lines.append(f"  {name}:")
        for key, value in zip(("x", "y", "z"), xyz / 1000.0):
            lines.append(f"    {key}: {_num(value)}")
        for key, value in zip(("roll", "pitch", "yaw"), rpy):
            lines.append(f"    {key}: {_num(value)}")
    lines.append(f"  hash: {k.hash}")
    return "\n".join(lines) + "\n"


def write_ur_kinematics(model: RobotModel, path: str | Path, *, source: str = "") -> Path:
    """Write the kinematics YAML atomically."""
    return atomic_write_text(path, ur_kinematics_yaml(model, source=source))
