"""Changes the virtual lab can make to its true robot after a calibration, on purpose, so that a
class (and the tests) can watch the Check step find them:

  tool:SIZE     the marker moves SIZE mm on the tool in a random direction (a bent or swapped tool)
  base:SIZE     the robot base moves SIZE mm and turns SIZE/10 degrees about a random axis relative
                to the cameras (a bumped robot or camera stand)
  jointK:SIZE   joint K's zero offset slips by SIZE degrees (SIZE mm for a prismatic joint)
  linkK:SIZE    link K bends: its length a grows by SIZE mm and its twist by SIZE/10 degrees
                (a change none of the simple diagnoses explains)
  mount:NAME    the tool changer mounts the robot's tool NAME (from the lab robot's "tools"): the
                lab measures that tool's first target, at its true offset (the robot file's offset
                plus the lab's own manufacturing error, drawn when the lab was made)

Sizes may be negative for joints and links. Directions are drawn from the lab's seed and
`seed`, so a change is reproducible. The lab's `true_robot` is replaced; the nominal robot
and the cameras are not touched.
"""
from __future__ import annotations

import re
from dataclasses import dataclass

import numpy as np

from core import transforms as tf
from core.errors import UsageError

KINDS = ("tool", "base", "joint", "link", "mount")
_MOUNT = re.compile(r"^\s*mount\s*:\s*(\S(?:.*\S)?)\s*$", re.I)
_SPEC = re.compile(r"^\s*(" + "|".join(KINDS[:4]) + r")(\d*)\s*:\s*([-+]?\d+(?:\.\d*)?(?:[eE][-+]?\d+)?)\s*$", re.I)
MAX_SIZE = 50.0


@dataclass(frozen=True)
class LabChange:
    """A change of the lab's true robot: `kind`, `size` (mm or deg) and, for a joint or link,
    the 1-based `joint` number."""

    kind: str
    size: float
    joint: int = 0
    tool: str = ""          # for kind "mount": the tool's name

    def __str__(self) -> str:
        if self.kind == "mount":
            return f"mount:{self.tool}"
        return f"{self.kind}{self.joint if self.joint else ''}:{self.size:g}"

    def describe(self) -> str:
        if self.kind == "mount":
            return f"the tool '{self.tool}' is mounted"
        if self.kind == "tool":
            return f"the marker moved {abs(self.size):g} mm on the tool"
        if self.kind == "base":
            return f"the robot base moved {abs(self.size):g} mm and turned {abs(self.size) / 10:g}°"
        if self.kind == "joint":
            return f"joint {self.joint}'s zero slipped by {self.size:+g}"
        return f"link {self.joint} bent ({self.size:+g} mm, {self.size / 10:+g}°)"


def parse_change(text: str, dof: int | None = None) -> LabChange:
    """A LabChange from 'tool:1.5', 'base:2', 'joint3:0.4', 'link2:1', 'mount:NAME'. Raises UsageError."""
    mount = _MOUNT.match(str(text))
    if mount:
        return LabChange("mount", 0.0, tool=mount.group(1))
    m = _SPEC.match(str(text))
    hint = "Write tool:MM, base:MM, jointK:DEG, linkK:MM or mount:TOOL (e.g. tool:1.5, joint3:0.4)."
    if not m:
        raise UsageError(f"cannot read the change {text!r}", hint=hint)
    kind, number, size = m.group(1).lower(), m.group(2), float(m.group(3))
    if kind in ("joint", "link"):
        if not number:
            raise UsageError(f"the change {text!r} needs a joint number", hint=hint)
        k = int(number)
        if k < 1 or (dof is not None and k > dof):
            raise UsageError(f"the change {text!r} names joint {k}; the robot has joints 1 … {dof}", hint=hint)
    else:
        if number:
            raise UsageError(f"the change {text!r} takes no number after '{kind}'", hint=hint)
        k = 0
        if size <= 0:
            raise UsageError(f"the size of a {kind} change must be positive, got {size:g} mm", hint=hint)
    if not 0 < abs(size) <= MAX_SIZE:
        raise UsageError(f"the size of a change must be within ±{MAX_SIZE:g} and not 0, got {size:g}", hint=hint)
    return LabChange(kind, size, k)


def _unit(rng: np.random.Generator) -> np.ndarray:
    v = rng.normal(size=3)
    return v / np.linalg.norm(v)


def mount_tool(lab, tool: str) -> None:
    """Mount the lab robot's `tool`: the lab measures its first target from now on. Raises
    UsageError for a tool the lab's robot does not define."""
    tools = lab.nominal_robot.tool_map()
    if tool not in tools:
        raise UsageError(f"the virtual lab's robot has no tool '{tool}' (its tools: {', '.join(tools)})",
                         hint="Build the lab from the robot file that defines the tool (its \"tools\" section).")
    lab.target = tools[tool][0]


CHANGE_SEED = 0     # one direction per simulated change: the Check step's lab and sim-robot see the same one


def apply_change(lab, change: LabChange | str, *, seed: int = CHANGE_SEED) -> LabChange:
    """Change `lab`'s true robot in place (see the module); returns the change applied."""
    true = lab.true_robot
    if isinstance(change, str):
        change = parse_change(change, true.dof)
    if change.kind == "mount":
        mount_tool(lab, change.tool)
        return change
    if change.kind in ("joint", "link") and not 1 <= change.joint <= true.dof:
        raise UsageError(f"joint {change.joint} does not exist; the robot has joints 1 … {true.dof}")
    rng = np.random.default_rng(np.random.SeedSequence([int(lab.seed), int(seed), 14]))
    robot = true.copy()
    size = float(change.size)
    if change.kind == "tool":
        target = lab.target
        robot.targets[target] = np.asarray(robot.targets[target], dtype=float) + size * _unit(rng)
    elif change.kind == "base":
        base = robot.base.copy()
        R = tf.rot_axis(_unit(rng), np.deg2rad(size / 10.0))
        base[:3, :3] = R @ base[:3, :3]
        base[:3, 3] = base[:3, 3] + size * _unit(rng)
        robot.base = base
    elif change.kind == "joint":
        j = robot.joints[change.joint - 1]
        if j.revolute:
            j.theta += np.deg2rad(size)
        else:
            j.d += size
    else:
        j = robot.joints[change.joint - 1]
        j.a += size
        j.alpha += np.deg2rad(size / 10.0)
    lab.true_robot = robot
    return change
