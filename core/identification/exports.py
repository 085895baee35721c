"""Exports of a robot model: the DH table as CSV and a kinematic URDF (docs/file-formats.md).

DH table CSV (RFC 4180: comma-separated, CRLF line ends, text quoted where needed), always the
same 16 columns, one row per joint:
`joint,type,theta_deg,d_mm,a_mm,alpha_deg,beta_deg,min_deg,max_deg,min_mm,max_mm` (joint limits
in the deg pair for revolute, the mm pair for prismatic joints, the other pair empty) and the
standard deviations `theta_std_deg,d_std_mm,a_std_mm,alpha_std_deg,beta_std_deg` (empty where
a parameter was not estimated, and for a model that carries no calibration). A model with
deflection terms (core.robot.compliance) gets one `#` comment line before the header saying that
the table cannot hold them.

URDF (metres and radians, as URDF requires), a kinematic model with no visuals or inertias:
    world ─(fixed base_joint: base pose)→ base_link = DH frame 0
    for each joint i: link{i-1} ─(<name>: origin Rz(θ_i) [·Tz(d_i) if prismatic], axis z)→ <name>_moving
                      <name>_moving ─(fixed <name>_dh: Tz(d_i)·Tx(a_i)·Rx(α_i)·Ry(β_i) [Tz omitted
                      if prismatic])→ link{i} = DH frame i
    link{n} ─(fixed tool_joint: tool pose)→ tool ─(fixed <target>_joint: offset)→ one link per
    target (e.g. `marker`)
so every `link{i}` is exactly our DH frame i and a URDF library's forward kinematics equals
RobotModel's (the `world` frame is the measurement frame). <name> is the robot file's joint
name, so the URDF's joints match the robot's joint states: characters other than ASCII letters,
digits and `_` become `_`, a leading digit gets a `_` in front, and a name already taken gets
`_2`, `_3`… (`urdf_names`). Effort and velocity limits are not known to RoboCal; they are
written as 0 with a comment (fill them in before using the URDF for motion planning).
Neither format can hold deflection terms: for a model that has them, a comment says so and names
the robot JSON file as the complete model.
"""
from __future__ import annotations

import csv
import io
import re
from dataclasses import dataclass
from pathlib import Path
from xml.sax.saxutils import quoteattr

import numpy as np

from core import transforms as tf
from core.errors import RoboCalError
from core.files import atomic_write_text
from core.robot.model import RobotModel

DH_COLUMNS = ["joint", "type", "theta_deg", "d_mm", "a_mm", "alpha_deg", "beta_deg",
              "min_deg", "max_deg", "min_mm", "max_mm"]
STD_COLUMNS = ["theta_std_deg", "d_std_mm", "a_std_mm", "alpha_std_deg", "beta_std_deg"]
CSV_COLUMNS = DH_COLUMNS + STD_COLUMNS
FORMATS = ("urdf", "dh-csv")


def _num(v: float) -> str:
    """Shortest text that reads back as the same float."""
    v = float(v)
    return "0" if v == 0 else repr(v)


def _short(v: float) -> str:
    """10 significant digits for the CSV table (1e-7 mm / deg at worst)."""
    text = f"{float(v):.10g}"
    return "0" if text in ("0", "-0") else text


def _std_table(model: RobotModel) -> dict[str, float | None]:
    cal = model.calibration
    if not isinstance(cal, dict) or not isinstance(cal.get("parameters"), list):
        return {}
    return {row.get("name"): row.get("std") for row in cal["parameters"] if isinstance(row, dict)}


def compliance_note(model: RobotModel) -> str:
    """One line for a model with deflection terms: the export cannot hold them ("" without)."""
    if model.compliance is None or model.compliance.is_zero:
        return ""
    joints = sorted({f"J{j + 1}" for j, _ in model.compliance.terms})
    return (f"This model also has deflection terms ({', '.join(joints)} bend under the arm's weight) that this "
            f"format cannot hold: positions computed from it alone miss that deflection. The robot JSON "
            f"file keeps the complete model.")


def dh_table_csv(model: RobotModel) -> str:
    """The DH table as CSV text (`CSV_COLUMNS`; standard deviations from the model's calibration),
    after a `#` line saying so when the model has deflection terms the table cannot hold."""
    stds = _std_table(model)
    out = io.StringIO()
    note = compliance_note(model)
    if note:
        out.write(f"# {note}\r\n")
    writer = csv.writer(out)                     # quotes a name holding a comma, quote or line break
    writer.writerow(CSV_COLUMNS)
    for i, j in enumerate(model.joints):
        limits = [_short(np.rad2deg(j.min)), _short(np.rad2deg(j.max)), "", ""] if j.revolute \
            else ["", "", _short(j.min), _short(j.max)]
        stds_i = [stds.get(f"J{i + 1}.{kind}") for kind in ("theta", "d", "a", "alpha", "beta")]
        writer.writerow([j.name or f"J{i + 1}", j.type, _short(np.rad2deg(j.theta)), _short(j.d), _short(j.a),
                         _short(np.rad2deg(j.alpha)), _short(np.rad2deg(j.beta)), *limits,
                         *("" if s is None else _short(s) for s in stds_i)])
    return out.getvalue()


# -- URDF ------------------------------------------------------------------------------------
_NOT_XML = re.compile("[\x00-\x08\x0b\x0c\x0e-\x1f\ud800-\udfff\ufffe\uffff]")


def _xml_text(text: str) -> str:
    """`text` without the characters XML 1.0 cannot hold (escape it as well where needed)."""
    return _NOT_XML.sub("", text)


def _comment_text(text: str) -> str:
    """`text` on one line, safe inside an XML comment (which may not hold `--`)."""
    return re.sub("-(?=-)", "- ", " ".join(_xml_text(text).split()))


def _origin(T: np.ndarray) -> str:
    xyz = T[:3, 3] / 1000.0
    rpy = tf.matrix_to_rpy(T[:3, :3])
    return (f'<origin xyz="{_num(xyz[0])} {_num(xyz[1])} {_num(xyz[2])}" '
            f'rpy="{_num(rpy[0])} {_num(rpy[1])} {_num(rpy[2])}"/>')


def _name(text: str) -> str:
    """ASCII letters, digits and `_`, not starting with a digit."""
    name = re.sub(r"[^A-Za-z0-9_]", "_", text)
    return name if name and not name[0].isdigit() else f"_{name}"


def _unique(name: str, used: set[str]) -> str:
    out, k = name, 2
    while out in used:
        out, k = f"{name}_{k}", k + 1
    used.add(out)
    return out


@dataclass(frozen=True)
class UrdfNames:
    """The names `urdf_text` writes. Per robot joint i (lists in joint order): `joints[i]` the
    moving joint, `moving[i]` the link it moves, `dh[i]` the fixed joint to DH frame `link{i+1}`.
    `base_joint` and `tool_joint` the fixed joints world → base_link and link{n} → tool. Per
    target: `target_links` and `target_joints` (its fixed joint from `tool`)."""

    joints: list[str]
    moving: list[str]
    dh: list[str]
    base_joint: str
    tool_joint: str
    target_links: dict[str, str]
    target_joints: dict[str, str]


def urdf_names(model: RobotModel) -> UrdfNames:
    """URDF names: the robot's joint names first (sanitised, made unique), then the rest."""
    used_joints: set[str] = set()
    joints = [_unique(_name(j.name or f"J{i + 1}"), used_joints) for i, j in enumerate(model.joints)]
    base_joint, tool_joint = _unique("base_joint", used_joints), _unique("tool_joint", used_joints)
    dh = [_unique(f"{jn}_dh", used_joints) for jn in joints]
    used_links = {"world", "base_link", "tool"} | {f"link{i + 1}" for i in range(model.dof)}
    moving = [_unique(f"{jn}_moving", used_links) for jn in joints]
    target_links, target_joints = {}, {}
    for target in model.targets:
        link = _name(target)
        target_links[target] = _unique(f"target_{link}" if link in used_links else link, used_links)
        target_joints[target] = _unique(f"{target_links[target]}_joint", used_joints)
    return UrdfNames(joints, moving, dh, base_joint, tool_joint, target_links, target_joints)


def urdf_text(model: RobotModel, robot_name: str | None = None) -> str:
    """A URDF document (metres, radians) whose forward kinematics equals the model's."""
    name = _xml_text(robot_name or model.name or "robot")
    names = urdf_names(model)
    out = ['<?xml version="1.0"?>',
           f"<!-- Exported by RoboCal from the model {_comment_text(model.name)}. Lengths in metres, angles in",
           "     radians. link{i} is DH frame i; world is the measurement (left camera) frame. Joint names",
           "     are the robot file's. effort and velocity limits are unknown to RoboCal and written as 0. -->"]
    note = compliance_note(model)
    if note:
        out.append(f"<!-- {_comment_text(note)} -->")
    out += [f"<robot name={quoteattr(name)}>",
            '  <link name="world"/>', '  <link name="base_link"/>',
            f'  <joint name="{names.base_joint}" type="fixed">', '    <parent link="world"/>',
            '    <child link="base_link"/>', f"    {_origin(model.base)}", "  </joint>"]
    parent = "base_link"
    for i, j in enumerate(model.joints):
        jn, moving, frame = names.joints[i], names.moving[i], f"link{i + 1}"
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
                f'  <joint name="{names.dh[i]}" type="fixed">', f'    <parent link="{moving}"/>',
                f'    <child link="{frame}"/>', f"    {_origin(post)}", "  </joint>"]
        parent = frame
    out += ['  <link name="tool"/>', f'  <joint name="{names.tool_joint}" type="fixed">',
            f'    <parent link="{parent}"/>', '    <child link="tool"/>', f"    {_origin(model.tool)}",
            "  </joint>"]
    for target, link in names.target_links.items():
        out += [f'  <link name="{link}"/>', f'  <joint name="{names.target_joints[target]}" type="fixed">',
                '    <parent link="tool"/>', f'    <child link="{link}"/>',
                f"    {_origin(tf.make_transform(None, model.targets[target]))}", "  </joint>"]
    out.append("</robot>")
    return "\n".join(out) + "\n"


def target_links(model: RobotModel) -> dict[str, str]:
    """The URDF link name of each target (as written by `urdf_text`)."""
    return urdf_names(model).target_links


def export_model(model: RobotModel, fmt: str, path: str | Path) -> Path:
    """Write `model` as 'urdf' or 'dh-csv' to `path`, atomically."""
    if fmt == "urdf":
        return atomic_write_text(path, urdf_text(model))
    if fmt == "dh-csv":
        return atomic_write_text(path, dh_table_csv(model))
    raise RoboCalError(f"unknown export format '{fmt}'", hint=f"Use one of: {', '.join(FORMATS)}.")
