"""The robot model file `robot.json` (format robocal.robot/1, DESIGN.md): read, validate, write.

Files hold millimetres and degrees; the in-memory `RobotModel` holds millimetres and radians.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from core import transforms as tf
from core.errors import RoboCalError
from core.files import atomic_write_json, read_json
from core.robot.compliance import FORMAT as COMPLIANCE_FORMAT
from core.robot.compliance import FORMAT_FAMILY as COMPLIANCE_FAMILY
from core.robot.compliance import FORMAT_MAJOR as COMPLIANCE_MAJOR
from core.robot.compliance import SHAPES, Compliance, check_vertical_arm
from core.robot.model import PRISMATIC, REVOLUTE, Joint, RobotModel, preset_names, robot_path
from core.validate import check_format, name_text, number, require, text, vector

FORMAT_FAMILY = "robocal.robot"
FORMAT_MAJOR = 1
FORMAT = f"{FORMAT_FAMILY}/{FORMAT_MAJOR}"


def robot_file(value: str | Path) -> Path:
    """The robot file a user named: an existing path, else a preset of resources/robots by its
    name (`educational_6r`, `ur5`, with or without `.json`), so a command runs from any folder.
    A value that is neither raises RoboCalError listing the presets."""
    path = Path(value)
    if path.exists():
        return path
    name = path.name[:-5] if path.name.endswith(".json") else path.name
    if path.parent == Path(".") and name in preset_names():
        return robot_path(name)
    if path.parent == Path("."):
        raise RoboCalError("file not found, and not the name of a preset robot", source=str(value),
                           hint=f"Give the path of a robot file, or a preset by name: {', '.join(preset_names())}.")
    raise RoboCalError("file not found", source=str(value),
                       hint=f"Check the path, or name a preset robot instead: {', '.join(preset_names())}.")


def read_robot(path: str | Path) -> RobotModel:
    """Read and validate a robot file, or a preset by name (`robot_file`); raises
    RoboCalError naming the file and field."""
    path = robot_file(path)
    return robot_from_dict(read_json(path), source=path)


def write_robot(model: RobotModel, path: str | Path) -> Path:
    """Write atomically (a failure leaves any previous file intact)."""
    return atomic_write_json(path, robot_to_dict(model))


def _pose_from_dict(data, source, field: str) -> np.ndarray:
    if data is None:
        return np.eye(4)
    if not isinstance(data, dict):
        raise RoboCalError("expected an object with 'xyz' and 'rpy'", source=source, field=field)
    xyz = vector(data.get("xyz", [0, 0, 0]), 3, source, f"{field}.xyz", "mm")
    rpy = vector(data.get("rpy", [0, 0, 0]), 3, source, f"{field}.rpy", "degrees")
    return tf.pose_to_matrix(xyz, np.deg2rad(rpy))


def _pose_to_dict(T: np.ndarray) -> dict:
    xyz, rpy = tf.matrix_to_pose(T)
    return {"xyz": [float(v) for v in xyz], "rpy": [float(v) for v in np.rad2deg(rpy)]}


def robot_from_dict(data: dict, source: str | Path = "<robot>") -> RobotModel:
    check_format(data, FORMAT_FAMILY, FORMAT_MAJOR, source)
    units = data.get("units", {"length": "mm", "angle": "deg"})
    if not isinstance(units, dict) or units.get("length", "mm") != "mm" or units.get("angle", "deg") != "deg":
        raise RoboCalError(f"unsupported units {units!r}", source=source, field="units",
                           hint='RoboCal robot files use {"length": "mm", "angle": "deg"}.')
    name = text(data.get("name", Path(str(source)).stem), source, "name")
    joints_data = require(data, "joints", source)
    if not isinstance(joints_data, list) or not joints_data:
        raise RoboCalError("expected a non-empty list of joints", source=source, field="joints")
    joints = []
    for i, jd in enumerate(joints_data):
        f = f"joints[{i}]"
        if not isinstance(jd, dict):
            raise RoboCalError("expected an object", source=source, field=f)
        jtype = jd.get("type", REVOLUTE)
        if jtype not in (REVOLUTE, PRISMATIC):
            raise RoboCalError(f"unknown joint type {jtype!r}", source=source, field=f"{f}.type",
                               hint="Use 'revolute' or 'prismatic'.")
        revolute = jtype == REVOLUTE
        values = {}
        for key, unit in (("theta", "degrees"), ("d", "mm"), ("a", "mm"), ("alpha", "degrees")):
            values[key] = number(require(jd, key, source, f"{f}.{key}"), source, f"{f}.{key}", unit)
        values["beta"] = number(jd.get("beta", 0.0), source, f"{f}.beta", "degrees")
        limit_unit = "degrees" if revolute else "mm"
        lo = number(require(jd, "min", source, f"{f}.min"), source, f"{f}.min", limit_unit)
        hi = number(require(jd, "max", source, f"{f}.max"), source, f"{f}.max", limit_unit)
        if lo >= hi:
            raise RoboCalError(f"min ({lo}) must be smaller than max ({hi})", source=source, field=f"{f}.min")
        scale = np.deg2rad(1.0) if revolute else 1.0
        joints.append(Joint(
            type=jtype, theta=np.deg2rad(values["theta"]), d=values["d"], a=values["a"],
            alpha=np.deg2rad(values["alpha"]), beta=np.deg2rad(values["beta"]),
            min=lo * scale, max=hi * scale, name=text(jd.get("name", f"J{i + 1}"), source, f"{f}.name")))
    targets_data = data.get("targets", {})
    if not isinstance(targets_data, dict):
        raise RoboCalError("expected an object of name: [x, y, z]", source=source, field="targets")
    targets = {name_text(k, source, f"targets.{k}"): np.array(vector(v, 3, source, f"targets.{k}", "mm"))
               for k, v in targets_data.items()}            # a target becomes a link of the exported URDF
    calibration = _calibration_from_dict(data.get("calibration"), source)
    model = RobotModel(name=name, joints=joints, base=_pose_from_dict(data.get("base"), source, "base"),
                       tool=_pose_from_dict(data.get("tool"), source, "tool"), targets=targets,
                       calibration=calibration,
                       collision_radius=_collision_from_dict(data.get("collision"), len(joints), source),
                       tools=_tools_from_dict(data.get("tools"), targets, source),
                       target_rotations=_rotations_from_dict(data.get("target_rotations"), targets, source))
    if data.get("compliance") is not None:
        model.compliance = _compliance_from_dict(data["compliance"], len(joints), source)
        check_vertical_arm(model, source=source)
    return model


def _compliance_from_dict(data, dof: int, source) -> Compliance:
    """Optional `"compliance"` (format robocal.compliance/1, docs/file-formats.md): the gravity
    direction in the base frame and, per joint ("J2"), its deflection coefficients in degrees per
    shape (sin_q2, cos_q2, sin_q23, cos_q23). Absent: a rigid arm."""
    if not isinstance(data, dict):
        raise RoboCalError("expected an object with \"format\", \"gravity\" and \"joints\"", source=source,
                           field="compliance")
    check_format(data, COMPLIANCE_FAMILY, COMPLIANCE_MAJOR, f"{source}: compliance")
    if data.get("unit", "deg") != "deg":
        raise RoboCalError(f"unsupported unit {data.get('unit')!r}", source=source, field="compliance.unit",
                           hint='Deflection coefficients are written in degrees: "unit": "deg".')
    gravity = np.array(vector(data.get("gravity", [0.0, 0.0, -1.0]), 3, source, "compliance.gravity"))
    if np.linalg.norm(gravity) <= 0:
        raise RoboCalError("the gravity direction must not be zero", source=source, field="compliance.gravity",
                           hint="Write [0, 0, -1] for a floor-mounted robot, [0, 0, 1] for one on the ceiling.")
    joints = data.get("joints", {})
    if not isinstance(joints, dict):
        raise RoboCalError('expected an object like {"J2": {"sin_q2": 0.01, …}}', source=source,
                           field="compliance.joints")
    out = Compliance.zero(dof, terms=(), gravity=gravity / np.linalg.norm(gravity))
    terms = []
    for label, shapes in joints.items():
        f = f"compliance.joints.{label}"
        index = int(label[1:]) - 1 if str(label)[:1] == "J" and str(label)[1:].isdigit() else -1
        if not 0 <= index < dof:
            raise RoboCalError(f"unknown joint '{label}'", source=source, field=f,
                               hint=f"Name joints J1 … J{dof}.")
        if not isinstance(shapes, dict):
            raise RoboCalError("expected an object of shape: degrees", source=source, field=f)
        for shape, value in shapes.items():
            if shape not in SHAPES:
                raise RoboCalError(f"unknown shape '{shape}'", source=source, field=f"{f}.{shape}",
                                   hint=f"Use {', '.join(SHAPES)}.")
            out.set(index, shape, np.deg2rad(number(value, source, f"{f}.{shape}", "degrees")))
            terms.append((index, shape))
    out.terms = tuple(terms)
    return out


def _compliance_to_dict(c: Compliance) -> dict:
    joints: dict[str, dict[str, float]] = {}
    for joint, shape in c.terms:
        joints.setdefault(f"J{joint + 1}", {})[shape] = float(np.rad2deg(c.coefficient(joint, shape)))
    return {"format": COMPLIANCE_FORMAT, "unit": "deg", "gravity": [float(v) for v in c.gravity],
            "joints": joints}


def _rotations_from_dict(data, targets: dict, source) -> dict[str, np.ndarray]:
    """Optional `"target_rotations": {"marker": [rx, ry, rz]}`: a target's frame in the tool frame
    as a rotation vector in degrees (written when identification estimated a marker's
    orientation); a target absent here is aligned with the tool frame."""
    if data is None:
        return {}
    if not isinstance(data, dict):
        raise RoboCalError("expected an object of target name: [rx, ry, rz] (degrees)", source=source,
                           field="target_rotations")
    out = {}
    for name, value in data.items():
        f = f"target_rotations.{name}"
        if name not in targets:
            raise RoboCalError(f"target '{name}' is not in \"targets\"", source=source, field=f,
                               hint="Add its offset to \"targets\" or fix the name.")
        out[str(name)] = Rotation.from_rotvec(vector(value, 3, source, f, "degrees"), degrees=True).as_matrix()
    return out


def _tools_from_dict(data, targets: dict, source) -> dict[str, list[str]]:
    """Optional `"tools": {"name": ["target", …]}` (a tool changer): every target on exactly one
    tool. Absent: one tool with every target (an empty dict)."""
    if data is None:
        return {}
    hint = 'Write "tools": {"gripper": ["marker"], "long_gripper": ["long_marker"]} with the names of "targets".'
    if not isinstance(data, dict) or not data:
        raise RoboCalError("expected an object of tool name: [target names]", source=source, field="tools",
                           hint=hint)
    tools: dict[str, list[str]] = {}
    owner: dict[str, str] = {}
    for name, listed in data.items():
        f = f"tools.{name}"
        if not str(name).strip():
            raise RoboCalError("a tool needs a name", source=source, field="tools", hint=hint)
        if not isinstance(listed, list) or not listed or not all(isinstance(t, str) for t in listed):
            raise RoboCalError("expected a non-empty list of target names", source=source, field=f, hint=hint)
        for t in listed:
            if t not in targets:
                raise RoboCalError(f"target '{t}' is not in \"targets\"", source=source, field=f,
                                   hint="Add its offset to \"targets\" or fix the name.")
            if t in owner:
                raise RoboCalError(f"target '{t}' is on both '{owner[t]}' and '{name}'", source=source, field=f,
                                   hint="Give every tool its own target names.")
            owner[t] = str(name)
        tools[str(name)] = list(listed)
    loose = [t for t in targets if t not in owner]
    if loose:
        raise RoboCalError(f"target '{loose[0]}' is on no tool", source=source, field="tools",
                           hint="List every target under the tool that carries it.")
    return tools


def _calibration_from_dict(calibration, source) -> dict | None:
    """The calibration section as written by identification; its parameter table (name, nominal,
    identified, std: numbers or null) is checked, as the exports and the report read it."""
    if calibration is None:
        return None
    if not isinstance(calibration, dict):
        raise RoboCalError("expected an object", source=source, field="calibration")
    params = calibration.get("parameters", [])
    if not isinstance(params, list):
        raise RoboCalError("expected a list of parameters", source=source, field="calibration.parameters")
    for i, row in enumerate(params):
        f = f"calibration.parameters[{i}]"
        if not isinstance(row, dict):
            raise RoboCalError("expected an object", source=source, field=f)
        text(row.get("name", ""), source, f"{f}.name")
        for key in ("nominal", "identified", "std"):
            if row.get(key) is not None:
                number(row[key], source, f"{f}.{key}")
    return calibration


def _collision_from_dict(data, dof: int, source) -> np.ndarray | None:
    """Optional `"collision": {"radius": [mm per link]}` (dof values, or dof + 1 with the tool
    link last): capsule radii for the self-collision check of pose selection."""
    if data is None:
        return None
    if not isinstance(data, dict):
        raise RoboCalError('expected an object like {"radius": [mm per link]}', source=source, field="collision")
    radius = require(data, "radius", source, "collision.radius")
    if not isinstance(radius, list) or len(radius) not in (dof, dof + 1):
        raise RoboCalError(f"expected a list of {dof} (or {dof + 1} with the tool) radii in mm",
                           source=source, field="collision.radius")
    values = np.array([number(v, source, f"collision.radius[{i}]", "mm") for i, v in enumerate(radius)])
    if np.any(values < 0):
        raise RoboCalError("radii must not be negative", source=source, field="collision.radius")
    return values


def robot_to_dict(model: RobotModel) -> dict:
    joints = []
    for j in model.joints:
        scale = np.rad2deg(1.0) if j.revolute else 1.0
        joints.append({
            "name": j.name, "type": j.type,
            "theta": float(np.rad2deg(j.theta)), "d": float(j.d), "a": float(j.a),
            "alpha": float(np.rad2deg(j.alpha)), "beta": float(np.rad2deg(j.beta)),
            "min": float(j.min * scale), "max": float(j.max * scale)})
    out = {
        "format": FORMAT,
        "name": model.name,
        "units": {"length": "mm", "angle": "deg"},
        "joints": joints,
        "base": _pose_to_dict(model.base),
        "tool": _pose_to_dict(model.tool),
        "targets": {k: [float(v) for v in p] for k, p in model.targets.items()},
    }
    if model.tools:
        out["tools"] = {k: list(v) for k, v in model.tools.items()}
    if model.target_rotations:
        out["target_rotations"] = {k: [float(v) for v in Rotation.from_matrix(R).as_rotvec(degrees=True)]
                                   for k, R in model.target_rotations.items()}
    if model.collision_radius is not None:
        out["collision"] = {"radius": [float(v) for v in model.collision_radius]}
    if model.compliance is not None:
        out["compliance"] = _compliance_to_dict(model.compliance)
    if model.calibration is not None:
        out["calibration"] = model.calibration
    return out
