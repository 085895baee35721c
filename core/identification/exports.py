"""Exports of a robot model: the DH table as CSV and a kinematic URDF.

DH table CSV: one row per joint, `joint,type,theta_deg,d_mm,a_mm,alpha_deg,beta_deg,min,max`
(min/max in degrees for revolute, mm for prismatic joints) and, for a calibrated model, the
standard deviations `theta_std_deg,d_std_mm,a_std_mm,alpha_std_deg,beta_std_deg` (empty where a
parameter was not estimated).

URDF (metres and radians, as URDF requires), a kinematic model with no visuals or inertias:
    world ─(fixed: base pose)→ base_link = DH frame 0
    for each joint i: link{i-1} ─(Ji: origin Rz(θ_i) [·Tz(d_i) if prismatic], axis z)→ Ji_moving
                      Ji_moving ─(fixed Ji_dh: Tz(d_i)·Tx(a_i)·Rx(α_i)·Ry(β_i) [Tz omitted if
                      prismatic])→ link{i} = DH frame i
    link{n} ─(fixed: tool pose)→ tool ─(fixed: offset)→ one link per target (e.g. `marker`)
so every `link{i}` is exactly our DH frame i and a URDF library's forward kinematics equals
RobotModel's (the `world` frame is the measurement frame). Effort and velocity limits are not
known to RoboCal; they are written as 0 with a comment (fill them in before using the URDF
for motion planning).
"""
from __future__ import annotations

import re
from pathlib import Path
from xml.sax.saxutils import escape, quoteattr

import numpy as np

from core import transforms as tf
from core.errors import RoboCalError
from core.files import atomic_write_text
from core.robot.model import RobotModel

DH_COLUMNS = ["joint", "type", "theta_deg", "d_mm", "a_mm", "alpha_deg", "beta_deg", "min", "max"]
STD_COLUMNS = ["theta_std_deg", "d_std_mm", "a_std_mm", "alpha_std_deg", "beta_std_deg"]
FORMATS = ("urdf", "dh-csv")


def _num(v: float) -> str:
    """Shortest text that reads back as the same float."""
    v = float(v)
    return "0" if v == 0 else repr(v)


def _short(v: float) -> str:
    """10 significant digits for the CSV table (1e-7 mm / deg at worst)."""
    text = f"{float(v):.10g}"
    return "0" if text in ("0", "-0") else text


def _std_table(model: RobotModel) -> dict[str, float | None] | None:
    cal = model.calibration
    if not isinstance(cal, dict) or not isinstance(cal.get("parameters"), list):
        return None
    return {row.get("name"): row.get("std") for row in cal["parameters"] if isinstance(row, dict)}


def dh_table_csv(model: RobotModel) -> str:
    """The DH table as CSV text (with std columns when the model carries a calibration)."""
    stds = _std_table(model)
    cols = DH_COLUMNS + (STD_COLUMNS if stds is not None else [])
    lines = [",".join(cols)]
    for i, j in enumerate(model.joints):
        lim = np.rad2deg([j.min, j.max]) if j.revolute else (j.min, j.max)
        row = [f"J{i + 1}" if not j.name else j.name, j.type,
               _short(np.rad2deg(j.theta)), _short(j.d), _short(j.a), _short(np.rad2deg(j.alpha)),
               _short(np.rad2deg(j.beta)), _short(lim[0]), _short(lim[1])]
        if stds is not None:
            for kind in ("theta", "d", "a", "alpha", "beta"):
                s = stds.get(f"J{i + 1}.{kind}")
                row.append("" if s is None else _short(s))
        if any("," in c for c in row[:2]):
            raise RoboCalError(f"joint name {row[0]!r} contains a comma", hint="Rename the joint.")
        lines.append(",".join(row))
    return "\n".join(lines) + "\n"


# -- URDF ------------------------------------------------------------------------------------
def _origin(T: np.ndarray) -> str:
    xyz = T[:3, 3] / 1000.0
    rpy = tf.matrix_to_rpy(T[:3, :3])
    return (f'<origin xyz="{_num(xyz[0])} {_num(xyz[1])} {_num(xyz[2])}" '
            f'rpy="{_num(rpy[0])} {_num(rpy[1])} {_num(rpy[2])}"/>')


def _link_name(text: str) -> str:
    name = re.sub(r"[^A-Za-z0-9_]", "_", text)
    return name if name and not name[0].isdigit() else f"_{name}"


def urdf_text(model: RobotModel, robot_name: str | None = None) -> str:
    """A URDF document (metres, radians) whose forward kinematics equals the model's."""
    name = robot_name or model.name or "robot"
    out = ['<?xml version="1.0"?>',
           f"<!-- Exported by RoboCal from the model {escape(model.name)!s}. Lengths in metres, angles in",
           "     radians. link{i} is DH frame i; world is the measurement (left camera) frame.",
           "     effort and velocity limits are unknown to RoboCal and written as 0. -->",
           f"<robot name={quoteattr(name)}>",
           '  <link name="world"/>', '  <link name="base_link"/>',
           '  <joint name="base_joint" type="fixed">', '    <parent link="world"/>',
           '    <child link="base_link"/>', f"    {_origin(model.base)}", "  </joint>"]
    parent = "base_link"
    for i, j in enumerate(model.joints):
        jn, moving, frame = f"J{i + 1}", f"J{i + 1}_moving", f"link{i + 1}"
        if j.revolute:
            pre = tf.make_transform(tf.rot_z(j.theta))
            post = tf.make_transform(tf.rot_x(j.alpha) @ tf.rot_y(j.beta), [j.a, 0.0, j.d])
            lower, upper = j.min, j.max
        else:
            pre = tf.make_transform(tf.rot_z(j.theta), [0.0, 0.0, j.d])
            post = tf.make_transform(tf.rot_x(j.alpha) @ tf.rot_y(j.beta), [j.a, 0.0, 0.0])
            lower, upper = j.min / 1000.0, j.max / 1000.0
        out += [f'  <link name="{moving}"/>', f'  <link name="{frame}"/>',
                f'  <joint name="{jn}" type="{"revolute" if j.revolute else "prismatic"}">',
                f'    <parent link="{parent}"/>', f'    <child link="{moving}"/>',
                f"    {_origin(pre)}", '    <axis xyz="0 0 1"/>',
                f'    <limit lower="{_num(lower)}" upper="{_num(upper)}" effort="0" velocity="0"/>',
                "  </joint>",
                f'  <joint name="{jn}_dh" type="fixed">', f'    <parent link="{moving}"/>',
                f'    <child link="{frame}"/>', f"    {_origin(post)}", "  </joint>"]
        parent = frame
    out += ['  <link name="tool"/>', '  <joint name="tool_joint" type="fixed">',
            f'    <parent link="{parent}"/>', '    <child link="tool"/>', f"    {_origin(model.tool)}",
            "  </joint>"]
    for target, link in target_links(model).items():
        out += [f'  <link name="{link}"/>', f'  <joint name="{link}_joint" type="fixed">',
                '    <parent link="tool"/>', f'    <child link="{link}"/>',
                f"    {_origin(tf.make_transform(None, model.targets[target]))}", "  </joint>"]
    out.append("</robot>")
    return "\n".join(out) + "\n"


def target_links(model: RobotModel) -> dict[str, str]:
    """The URDF link name of each target (as written by `urdf_text`)."""
    used = {"world", "base_link", "tool"} | {f"link{i + 1}" for i in range(model.dof)} | \
        {f"J{i + 1}_moving" for i in range(model.dof)}
    out = {}
    for target in model.targets:
        link = _link_name(target)
        while link in used:
            link = f"target_{link}"
        used.add(link)
        out[target] = link
    return out


def export_model(model: RobotModel, fmt: str, path: str | Path) -> Path:
    """Write `model` as 'urdf' or 'dh-csv' to `path`, atomically."""
    if fmt == "urdf":
        return atomic_write_text(path, urdf_text(model))
    if fmt == "dh-csv":
        return atomic_write_text(path, dh_table_csv(model))
    raise RoboCalError(f"unknown export format '{fmt}'", hint=f"Use one of: {', '.join(FORMATS)}.")
