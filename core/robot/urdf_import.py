"""A nominal robot model from a URDF serial chain.

The chain from a base link to a tip link (revolute, continuous, prismatic and fixed joints) is
turned into standard DH rows (chapter eq. 1) plus a base and a tool transform, so that the
forward kinematics of both agree for every joint configuration:

- at the zero configuration each moving joint's axis is a line in the base link's frame
  (URDF units: metres and radians, converted to mm and degrees);
- DH frame i sits on the common normal between the axes of joints i and i+1 (for intersecting
  axes a = 0 and x is along z_{i-1} × z_i); θ or d at q = 0 becomes the joint's offset;
- axes within PARALLEL_DEG (5°) of parallel, where the common normal runs off (0.01° from a
  rounded URDF angle puts it kilometres away), take Hayati's form instead, as the
  identification does for such axes: d = 0, frame i where the plane through the previous
  origin normal to the axis meets the next axis, and the next axis' tilt as Rx(α)·Ry(β)
  (exactly parallel axes: β = 0, the plain DH row);
- the last frame is placed on the last axis, and whatever remains to the tip link, including
  the fixed joints after it, becomes the tool transform; the base link to the first DH frame
  becomes the base transform.

Refused with what to do: an unexpanded xacro file (run xacro first), a kinematic loop (named
by its links), a mimic joint on the chain imported (elsewhere, e.g. a gripper finger, it is
ignored), a tip that is the base link, and a chain longer than LONGEST_CHAIN_M (20 m): lengths
written in millimetres where URDF has metres.

URDF joints are read with the standard library's ElementTree (the format is a few elements).
"""
from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from core import transforms as tf
from core.errors import RoboCalError
from core.robot.model import PARALLEL_DEG, PRISMATIC, REVOLUTE, Joint, RobotModel, dh_matrices

M_TO_MM = 1000.0
_EPS = 1e-9
LONGEST_CHAIN_M = 20.0        # a chain longer than this (the sum of its joint offsets, m) is not an arm
                              # in metres: the largest industrial arms reach about 4 m


@dataclass
class _UrdfJoint:
    name: str
    type: str
    parent: str
    child: str
    origin: np.ndarray          # 4x4, parent link -> joint frame, mm
    axis: np.ndarray            # unit vector in the joint frame
    lower: float | None         # rad or mm
    upper: float | None
    mimic: bool = False         # coupled to another joint (refused only on the chain imported)


@dataclass
class UrdfImport:
    """The model and what was assumed while building it."""

    model: RobotModel
    base_link: str
    tip_link: str
    notes: list[str]


@dataclass
class UrdfLinks:
    """A URDF's links, each parent before its children, and the base and tip links the import
    takes when none is named (None where it cannot choose one; `why` then says why)."""

    links: list[str]
    base: str | None
    tip: str | None
    why: str = ""


def _floats(text: str | None, n: int, source, where: str) -> np.ndarray:
    if text is None:
        return np.zeros(n)
    try:
        values = np.array([float(v) for v in text.split()])
    except ValueError:
        raise RoboCalError(f"expected {n} number{'s' if n > 1 else ''}, got {text!r:.60}", source=source,
                           field=where) from None
    if values.shape != (n,) or not np.all(np.isfinite(values)):
        raise RoboCalError(f"expected {n} finite number{'s' if n > 1 else ''}, got {text!r:.60}", source=source,
                           field=where)
    return values


def _read(path: Path) -> tuple[str, dict[str, _UrdfJoint]]:
    try:
        root = ET.parse(path).getroot()
    except FileNotFoundError:
        raise RoboCalError("file not found", source=path, hint="Check the path of the URDF file.") from None
    except (ET.ParseError, OSError) as exc:
        if isinstance(exc, ET.ParseError) and "xacro:" in path.read_text(encoding="utf-8", errors="replace"):
            raise RoboCalError(f"an unexpanded xacro file, not a URDF ({exc})", source=path,
                               hint=f"Expand it first: xacro {path.name} > robot.urdf, then import robot.urdf.") from None
        raise RoboCalError(f"not a readable URDF (XML) file ({exc})", source=path) from None
    if root.tag != "robot":
        raise RoboCalError(f"the root element is <{root.tag}>, not <robot>", source=path, hint="Give a URDF file.")
    if _is_xacro(path, root):
        raise RoboCalError("this is an unexpanded xacro file (xacro macros, properties or ${...} expressions), "
                           "not a URDF", source=path,
                           hint=f"Expand it first: xacro {path.name} > robot.urdf (ROS's xacro tool, also on PyPI), "
                                "then import robot.urdf.")
    joints: dict[str, _UrdfJoint] = {}
    for el in root.findall("joint"):
        name = el.get("name", "")
        where = f"joint '{name}'"
        jtype = el.get("type", "")
        parent, child = el.find("parent"), el.find("child")
        if parent is None or child is None:
            raise RoboCalError("a joint without <parent> or <child>", source=path, field=where)
        origin = el.find("origin")
        xyz = _floats(origin.get("xyz") if origin is not None else None, 3, path, f"{where} origin xyz")
        rpy = _floats(origin.get("rpy") if origin is not None else None, 3, path, f"{where} origin rpy")
        axis_el = el.find("axis")
        axis = _floats(axis_el.get("xyz") if axis_el is not None else "1 0 0", 3, path, f"{where} axis")
        if jtype in ("revolute", "continuous", "prismatic"):
            norm = float(np.linalg.norm(axis))
            if norm < _EPS:
                raise RoboCalError("the joint axis is zero", source=path, field=where)
            axis = axis / norm
        limit = el.find("limit")
        lower = upper = None
        if limit is not None and jtype != "continuous":
            scale = M_TO_MM if jtype == "prismatic" else 1.0
            lower = _floats(limit.get("lower", "0"), 1, path, f"{where} limit lower")[0] * scale
            upper = _floats(limit.get("upper", "0"), 1, path, f"{where} limit upper")[0] * scale
        child_link = child.get("link", "")
        if child_link in {j.child for j in joints.values()}:
            raise RoboCalError(f"link '{child_link}' has two parent joints: the URDF is not a tree (a closed chain)",
                               source=path, field=where, hint="RoboCal models serial arms.")
        joints[name] = _UrdfJoint(name, jtype, parent.get("link", ""), child_link,
                                  tf.make_transform(tf.rpy_to_matrix(rpy), xyz * M_TO_MM), axis, lower, upper,
                                  el.find("mimic") is not None)
    if not joints:
        raise RoboCalError("the URDF has no joints", source=path, hint="Give the URDF of a robot arm.")
    return root.get("name", path.stem), joints


def _is_xacro(path: Path, root) -> bool:
    """Elements of a xacro namespace (…/wiki/xacro, under any host), or ${...} expressions in
    attributes. An expanded file may still declare the namespace: only its use counts."""
    for el in root.iter():
        if isinstance(el.tag, str) and (el.tag.startswith("{") and el.tag.split("}")[0].endswith("/xacro")
                                        or el.tag.startswith("xacro:")):
            return True
        if any("${" in v or "$(" in v for v in el.attrib.values()):
            return True
    return False


def _loop(by_child: dict[str, _UrdfJoint]) -> list[str]:
    """The links of a kinematic loop (each the child of the next one's joint), or []."""
    for start in sorted(by_child):
        seen, link = [], start
        while link in by_child and link not in seen:
            seen.append(link)
            link = by_child[link].parent
        if link in seen:
            return seen[seen.index(link):]
    return []


def _chain(path: Path, joints: dict[str, _UrdfJoint], base: str | None, tip: str | None) -> list[_UrdfJoint]:
    by_child = {j.child: j for j in joints.values()}
    links = {j.parent for j in joints.values()} | set(by_child)
    roots = sorted(links - set(by_child))
    loop = _loop(by_child)
    if loop:
        raise RoboCalError(f"a kinematic loop between the links {', '.join(repr(k) for k in loop)} "
                           f"(each is the parent of the one before it): the URDF is not a tree", source=path,
                           field=f"joint '{by_child[loop[0]].name}'", hint="RoboCal models serial arms.")
    if base is None:
        if len(roots) != 1:
            raise RoboCalError(f"the URDF has {len(roots)} root links ({', '.join(roots)})", source=path,
                               hint="Name the base link with --base.")
        base = roots[0]
    if tip is None:
        leaves = sorted(set(by_child) - {j.parent for j in joints.values()})
        moving_leaves = [leaf for leaf in leaves if _moving_count(by_child, base, leaf) > 0]
        if len(moving_leaves) != 1:
            raise RoboCalError(f"the URDF has {len(moving_leaves)} end links ({', '.join(moving_leaves)})",
                               source=path, hint="Name the tip link with --tip (e.g. the flange or tool link).")
        tip = moving_leaves[0]
    for link, option in ((base, "--base"), (tip, "--tip")):
        if link not in links:
            raise RoboCalError(f"no link named '{link}'", source=path, field=option,
                               hint=f"Links: {', '.join(sorted(links))}.")
    if tip == base:
        raise RoboCalError(f"the tip link '{tip}' is the base link: the chain has no joint", source=path,
                           field="--tip", hint="Give a tip link further along the arm (the flange or tool link).")
    chain, link = [], tip
    while link != base:
        if link not in by_child:
            raise RoboCalError(f"link '{tip}' is not below link '{base}'", source=path,
                               hint="Give a tip link that descends from the base link.")
        joint = by_child[link]
        if joint.type in ("floating", "planar"):
            raise RoboCalError(f"a {joint.type} joint cannot be part of a robot arm's chain", source=path,
                               field=f"joint '{joint.name}'")
        if joint.type not in ("revolute", "continuous", "prismatic", "fixed"):
            raise RoboCalError(f"unknown joint type '{joint.type}'", source=path, field=f"joint '{joint.name}'")
        if joint.mimic:
            raise RoboCalError("a mimic joint (coupled to another joint) cannot be part of a DH chain",
                               source=path, field=f"joint '{joint.name}'",
                               hint=f"Choose a tip link before it with --tip (e.g. '{joint.parent}').")
        chain.append(joint)
        link = joint.parent
    return chain[::-1]


def _moving_count(by_child: dict, base: str, leaf: str) -> int:
    n, link = 0, leaf
    while link in by_child and link != base:
        n += by_child[link].type != "fixed"
        link = by_child[link].parent
    return n if link == base else 0


def _nearly_parallel(z1, z2) -> bool:
    """Axes within PARALLEL_DEG of parallel (or antiparallel)."""
    return float(np.linalg.norm(np.cross(z1, z2))) < math.sin(math.radians(PARALLEL_DEG))


def _closest(p1, z1, p2, z2) -> tuple[np.ndarray, np.ndarray]:
    """Closest points of two lines that are not nearly parallel."""
    n = np.cross(z1, z2)
    nn = float(n @ n)
    d = p2 - p1
    t1 = float(np.cross(d, z2) @ n) / nn
    t2 = float(np.cross(d, z1) @ n) / nn
    return p1 + t1 * z1, p2 + t2 * z2


def _hayati(O, x_prev, z_prev, p_next, z_next) -> tuple[float, float, float, float, float]:
    """θ, d, a, α, β (mm, rad) of a DH row to a nearly parallel next axis, in Hayati's form:
    d = 0, the next frame's origin where the plane through O normal to z_prev meets the next
    axis, and the tilt of the next axis as Rx(α)·Ry(β) (exactly parallel: β = 0, as plain DH)."""
    c = p_next + float((O - p_next) @ z_prev) / float(z_next @ z_prev) * z_next
    normal = c - O
    a = float(np.linalg.norm(normal))
    x_new = normal / a if a > 1e-6 else x_prev           # on the same line: a = 0, x kept
    a = a if a > 1e-6 else 0.0
    theta = _angle_about(x_prev, x_new, z_prev)
    sin_beta = float(np.clip(z_next @ x_new, -1.0, 1.0))
    in_plane = z_next - sin_beta * x_new                 # z_next without its part along x_new
    alpha = _angle_about(z_prev, in_plane / np.linalg.norm(in_plane), x_new)
    return theta, 0.0, a, alpha, math.asin(sin_beta)


def _angle_about(a, b, axis) -> float:
    """Angle that turns unit vector a onto b about `axis` (both perpendicular to it)."""
    return math.atan2(float(np.cross(a, b) @ axis), float(a @ b))


def import_urdf(path: str | Path, *, base: str | None = None, tip: str | None = None) -> UrdfImport:
    """The DH model (with base and tool transforms) of the URDF chain from `base` to `tip`
    (the root and the single moving end link when not given). Lengths mm, angles radians."""
    path = Path(path)
    name, joints = _read(path)
    chain = _chain(path, joints, base, tip)
    base = base or chain[0].parent
    tip = tip or chain[-1].child
    length_m = sum(float(np.linalg.norm(j.origin[:3, 3])) for j in chain) / M_TO_MM
    if length_m > LONGEST_CHAIN_M:
        raise RoboCalError(f"the chain from '{base}' to '{tip}' is {length_m:.4g} m long: URDF lengths are metres, "
                           "and these look like millimetres", source=path, field="joint origin xyz",
                           hint="Write the URDF in metres (divide every length by 1000), then import it again.")
    moving = []                       # (urdf joint, axis point, axis direction) in the base link frame, q = 0
    T = np.eye(4)
    for j in chain:
        T = T @ j.origin
        if j.type != "fixed":
            moving.append((j, T[:3, 3].copy(), T[:3, :3] @ j.axis))
    T_tip = T
    if not moving:
        raise RoboCalError(f"no moving joint between '{base}' and '{tip}'", source=path)
    notes: list[str] = []
    # frame 0 on the first axis, x chosen perpendicular to it (towards the base link's x where possible)
    p0, z0 = moving[0][1], moving[0][2]
    x0 = np.array([1.0, 0.0, 0.0]) - z0[0] * z0
    if np.linalg.norm(x0) < 1e-6:
        x0 = np.array([0.0, 1.0, 0.0]) - z0[1] * z0
    x0 /= np.linalg.norm(x0)
    frame = tf.make_transform(np.column_stack([x0, np.cross(z0, x0), z0]), p0)
    base_T = frame.copy()
    dh: list[Joint] = []
    tilted: list[str] = []            # joints whose axis is nearly, not exactly, parallel to the next one
    for i, (j, p, z) in enumerate(moving):
        O, x_prev, z_prev = frame[:3, 3], frame[:3, 0], frame[:3, 2]
        beta = 0.0
        if i + 1 < len(moving) and _nearly_parallel(z_prev, moving[i + 1][2]):
            theta, d, a, alpha, beta = _hayati(O, x_prev, z_prev, *moving[i + 1][1:])
            next_frame = frame @ dh_matrices(theta, d, a, alpha, beta)
            if np.linalg.norm(np.cross(z_prev, moving[i + 1][2])) > 1e-9:     # beyond rounding
                tilted.append(j.name)
        else:
            if i + 1 < len(moving):
                p_next, z_next = moving[i + 1][1], moving[i + 1][2]
                c_a, c_b = _closest(O, z_prev, p_next, z_next)
                normal = c_b - c_a
                if np.linalg.norm(normal) > 1e-6:
                    x_new = normal / np.linalg.norm(normal)
                else:                                    # intersecting axes
                    x_new = np.cross(z_prev, z_next)
                    x_new /= np.linalg.norm(x_new)
                z_new = z_next
            else:                                        # the last axis: a frame on it, nearest the tip
                c_a = O + ((T_tip[:3, 3] - O) @ z_prev) * z_prev
                c_b, x_new, z_new = c_a, x_prev, z_prev
            d = float((c_a - O) @ z_prev)
            theta = _angle_about(x_prev, x_new, z_prev)
            a = float((c_b - c_a) @ x_new)
            alpha = _angle_about(z_prev, z_new, x_new)
            next_frame = tf.make_transform(np.column_stack([x_new, np.cross(z_new, x_new), z_new]), c_b)
        lo, hi = j.lower, j.upper
        if j.type == "prismatic":
            lo, hi = (lo, hi) if lo is not None and lo < hi else (-1000.0, 1000.0)
            dh.append(Joint(type=PRISMATIC, theta=theta, d=d, a=a, alpha=alpha, beta=beta, min=lo, max=hi,
                            name=j.name))
        else:
            if lo is None or not lo < hi:
                lo, hi = -math.pi, math.pi
                notes.append(f"joint '{j.name}' has no limits in the URDF: ±180° assumed")
            dh.append(Joint(type=REVOLUTE, theta=theta, d=d, a=a, alpha=alpha, beta=beta, min=lo, max=hi,
                            name=j.name))
        frame = next_frame
    if tilted:
        notes.append(f"the axes after joint(s) {', '.join(repr(n) for n in tilted)} are within "
                     f"{PARALLEL_DEG:g}° of parallel: Hayati's form (d = 0, the tilt in α and β)")
    tool = tf.invert(frame) @ T_tip
    if not np.allclose(tool, np.eye(4), atol=1e-9):
        notes.append(f"the tip link '{tip}' is not the last DH frame: the difference is the tool transform")
    model = RobotModel(name=name, joints=dh, base=base_T, tool=tool)
    return UrdfImport(model, base, tip, notes)


def urdf_links(path: str | Path) -> UrdfLinks:
    """The links of the URDF at `path` (to choose a chain's base and tip) with the defaults
    `import_urdf` takes. A file that is not a URDF (an unexpanded xacro, no joints…) is refused."""
    path = Path(path)
    _, joints = _read(path)
    children: dict[str, list[str]] = {}
    for j in joints.values():
        children.setdefault(j.parent, []).append(j.child)
    by_child = {j.child for j in joints.values()}
    roots = sorted({j.parent for j in joints.values()} - by_child)
    links: list[str] = []
    stack = roots[::-1]
    while stack:                                   # depth first, in the file's order of joints
        link = stack.pop()
        if link in links:
            continue
        links.append(link)
        stack.extend(children.get(link, [])[::-1])
    links += sorted(by_child - set(links))         # links of a loop (refused by the import)
    base = roots[0] if len(roots) == 1 else None
    try:
        chain = _chain(path, joints, None, None)
    except RoboCalError as exc:
        return UrdfLinks(links, base, None, exc.problem)
    return UrdfLinks(links, chain[0].parent, chain[-1].child)


def urdf_forward_kinematics(path: str | Path, q, *, base: str | None = None, tip: str | None = None) -> np.ndarray:
    """The tip link's pose (4x4, mm) in the base link's frame for joint values q (rad / mm),
    computed along the URDF chain itself — the reference the DH model is checked against."""
    path = Path(path)
    _, joints = _read(path)
    T = np.eye(4)
    k = 0
    for j in _chain(path, joints, base, tip):
        T = T @ j.origin
        if j.type in ("revolute", "continuous"):
            T = T @ tf.make_transform(tf.rot_axis(j.axis, float(q[k])))
            k += 1
        elif j.type == "prismatic":
            T = T @ tf.make_transform(None, j.axis * float(q[k]))
            k += 1
    return T
