"""A corrected joint program as a controller runs it: a G-code program for a GRBL joint arm and
a move list in RoboCal's serial protocol (docs/robot-protocol.md).

Each point becomes the profile's move command (core.robot.profile.ProtocolProfile.format_move)
for the controller's joint values (core.robot.joint_map: sign, offset, units), in order:

* G-code (profile `grbl_joint_arm`): `G90` once, then `G0 X… Y… Z… A… B… C…` per point (axes
  X Y Z A B C are joints 1–6 in degrees); `;` comments name the robot and each point; `M2` ends
  the program. GRBL streams it line by line (each line answered `ok`).
* Moves (profile `robocal_v1`): `MOVE q1 … qn` per point; `#` comment lines name the robot and
  the points (a sender skips them; the controller never sees them).

A point outside the robot's joint limits is refused (RoboCalError naming it): a controller
program must never carry one.
"""
from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from core.errors import RoboCalError
from core.files import atomic_write_text
from core.robot.joint_map import JointMap
from core.robot.model import RobotModel
from core.robot.profile import ProtocolProfile, builtin_profile

_NEGATIVE_ZERO = re.compile(r"(?<![\d.])-(0(?:\.0+)?)(?![\d.])")      # "-0.000" -> "0.000"
FORMATS = {"gcode": ("grbl_joint_arm", ";"), "moves": ("robocal_v1", "#")}


def _safe(text: str, kind: str) -> str:
    """`text` for a comment: printable, and without the parentheses G-code reads as comments."""
    banned = "()" if kind == "gcode" else ""
    return "".join(c if c.isprintable() and c not in banned else "_" for c in str(text))


def format_controller_program(model: RobotModel, Q, names, kind: str, *, profile: ProtocolProfile | None = None,
                              joint_map: JointMap | dict | None = None, source: str = "") -> str:
    """The text of a `kind` ("gcode" or "moves") program for the joints Q (N, n, internal units)."""
    if kind not in FORMATS:
        raise RoboCalError(f"unknown controller program format '{kind}'", hint="Use gcode or moves.")
    profile = profile or builtin_profile(FORMATS[kind][0])
    comment = FORMATS[kind][1]
    Q = np.atleast_2d(np.asarray(Q, dtype=float))
    if profile.dof is not None and profile.dof < model.dof:
        raise RoboCalError(f"the protocol '{profile.name}' drives {profile.dof} joints but the robot has {model.dof}",
                           hint="Use a profile for this robot's joint count.")
    if not isinstance(joint_map, JointMap):
        joint_map = JointMap.from_dict(model.revolute_mask(), joint_map or profile.joints)
    inside = model.within_limits(Q)
    if not inside.all():
        i = int(np.flatnonzero(~inside)[0])
        raise RoboCalError(f"point '{names[i]}' is outside the joint limits of '{model.name}'",
                           hint="Correct the program again; no controller program is written with it.")
    protocol = Path(profile.source).stem if profile.source else profile.name
    lines = [f"{comment} RoboCal corrected program for {_safe(model.name, kind)}: {len(Q)} points"
             + (f" from {_safe(source, kind)}" if source else ""),
             f"{comment} protocol {_safe(protocol, kind)}; joint units {joint_map.units}"]
    if kind == "gcode":
        lines.append("G90")
    for name, q in zip(names, Q):
        move = _NEGATIVE_ZERO.sub(r"\1", profile.format_move(joint_map.to_controller(q)))
        if kind == "gcode":
            move = move.replace("G90 ", "", 1)
            lines.append(f"{move} ; {_safe(name, kind)}")
        else:
            lines.append(f"{comment} {_safe(name, kind)}")
            lines.append(move)
    if kind == "gcode":
        lines.append("M2")
    return "\n".join(lines) + "\n"


def write_controller_program(path: str | Path, model: RobotModel, Q, names, kind: str, **kw) -> Path:
    """Write the program atomically."""
    return atomic_write_text(path, format_controller_program(model, Q, names, kind, **kw))
