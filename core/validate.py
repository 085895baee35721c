"""Field checks for reading files: each failure names the file, the field and the fix."""
from __future__ import annotations

import math
import re
from pathlib import Path
from typing import Any

from core.bounds import ANGLE_DEG, LENGTH_MM, Bound
from core.errors import RoboCalError

#: the plausibility bound of a number read with this unit (core.bounds)
UNIT_BOUNDS: dict[str, Bound] = {"mm": LENGTH_MM, "degrees": ANGLE_DEG, "deg": ANGLE_DEG}


def check_format(data: dict, family: str, major: int, source: str | Path) -> int:
    """Check a `"format": "family/major[.minor]"` tag; return the minor version (0 if none)."""
    tag = data.get("format")
    if tag is None:
        raise RoboCalError("missing", source=source, field="format",
                           hint=f'Add "format": "{family}/{major}".')
    if not isinstance(tag, str) or "/" not in tag:
        raise RoboCalError(f"expected text like '{family}/{major}', got {tag!r}", source=source, field="format")
    name, _, version = tag.partition("/")
    if name != family:
        raise RoboCalError(f"this is a '{name}' file, expected '{family}'", source=source, field="format",
                           hint="Check that you opened the right file.")
    major_text, _, minor_text = version.partition(".")
    if not major_text.isdigit() or (minor_text and not minor_text.isdigit()):
        raise RoboCalError(f"bad version '{version}'", source=source, field="format",
                           hint=f"Use '{family}/{major}'.")
    if int(major_text) != major:
        raise RoboCalError(f"unknown format version {major_text} (this RoboCal reads version {major})",
                           source=source, field="format",
                           hint="Use a RoboCal release that reads this version, or re-export the file.")
    return int(minor_text or 0)


def require(data: dict, key: str, source, field: str | None = None) -> Any:
    if not isinstance(data, dict) or key not in data:
        raise RoboCalError("missing", source=source, field=field or key,
                           hint="Add it (see docs/file-formats.md).")
    return data[key]


def number(value: Any, source, field: str, unit: str = "") -> float:
    """A finite number (bools and text are refused), within the plausibility bound of its unit."""
    what = f"a number{' in ' + unit if unit else ''}"
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        shown = f"the text {value!r}" if isinstance(value, str) else repr(value)
        raise RoboCalError(f"expected {what}, got {shown}", source=source, field=field,
                           hint="Write a plain number without quotes or units.")
    try:
        value = float(value)
    except OverflowError:                  # an integer with hundreds of digits
        raise RoboCalError(f"expected {what}, got a number too large to use", source=source, field=field) from None
    if not math.isfinite(value):
        raise RoboCalError(f"expected {what}, got {value!r}", source=source, field=field)
    bound = UNIT_BOUNDS.get(unit)
    return bound.check(value, source=source, field=field) if bound is not None else value


def vector(value: Any, length: int, source, field: str, unit: str = "") -> list[float]:
    if not isinstance(value, (list, tuple)) or len(value) != length:
        raise RoboCalError(f"expected a list of {length} numbers, got {value!r}", source=source, field=field)
    return [number(v, source, f"{field}[{i}]", unit) for i, v in enumerate(value)]


def text(value: Any, source, field: str) -> str:
    if not isinstance(value, str):
        raise RoboCalError(f"expected text, got {value!r}", source=source, field=field)
    return value


NAME_MAX = 64
_NAME = re.compile(r"[^\W_][\w .+-]*")


def name_text(value: Any, source, field: str) -> str:
    """A name that may become a file name or a URDF link name (a fixture point, a target): a
    letter or digit first, then letters, digits, spaces and _ . + -, at most NAME_MAX characters,
    never '..' (no path, no wildcard, no markup)."""
    value = text(value, source, field)
    if not _NAME.fullmatch(value) or value != value.rstrip() or ".." in value or len(value) > NAME_MAX:
        shown = value if len(value) <= 40 else value[:40] + "…"
        raise RoboCalError(f"the name {shown!r} cannot be used: it becomes a file or link name", source=source,
                           field=field, hint=f"Use letters, digits, spaces and _ . + - (a letter or digit first, "
                                             f"at most {NAME_MAX} characters), e.g. 'A' or 'corner_1'.")
    return value
