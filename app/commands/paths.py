"""Which files a command reads and writes, checked before any work starts.

Each command module may declare ``INPUTS`` and ``OUTPUTS``: tuples of argparse destinations
(a file, a folder, or a list of them), named in messages as ``--dest``, or as LABEL when
written ``"dest=LABEL"`` (positional arguments). ``OUTPUTS`` entries may also be
``"dest/NAME"`` for a file NAME written inside the folder given by ``dest`` (``"ros/left.yaml"``).

- An output that is the same file as an input, or as another output, is a usage error (exit 2):
  a run must never overwrite what it reads.
- An output that is an existing image inside an input folder is refused the same way.
- An output that exists and is a device, a pipe or a socket is refused (exit 1) before any work:
  a rename would replace it with a regular file (core.files.require_regular_file; a folder is
  left to the command, as some outputs are folders).
- While the command runs, every output is held by an advisory lock (core.locks), so a second
  run writing the same file is refused with the number of the process that holds it.
"""
from __future__ import annotations

import os
from pathlib import Path
from typing import Iterable

from core.errors import UsageError
from core.files import require_regular_file
from core.images import IMAGE_SUFFIXES


def _values(args, dest: str) -> list[Path]:
    value = getattr(args, dest, None)
    if value is None or value == "" or value is False:
        return []
    items = value if isinstance(value, (list, tuple)) else [value]
    return [Path(v) for v in items if v not in (None, "")]


def _option(dest: str) -> str:
    return "--" + dest.replace("_", "-")


def declared(args, names: Iterable[str]) -> list[tuple[str, Path]]:
    """(option name, path) for each declared destination that was given."""
    found = []
    for name in names:
        name, _, label = name.partition("=")
        dest, _, inside = name.partition("/")
        for path in _values(args, dest):
            found.append((label or _option(dest), path / inside if inside else path))
    return found


def same_file(a: Path, b: Path) -> bool:
    """True when `a` and `b` name the same file (existing or not)."""
    try:
        if a.exists() and b.exists():
            return os.path.samefile(a, b)
    except OSError:
        pass
    return os.path.abspath(a) == os.path.abspath(b)


def check_overlaps(args, module) -> list[Path]:
    """Refuse outputs that overwrite an input or each other; return the output paths."""
    inputs = declared(args, getattr(module, "INPUTS", ()))
    outputs = declared(args, getattr(module, "OUTPUTS", ()))
    for i, (o_name, o_path) in enumerate(outputs):
        if not o_path.is_dir():
            require_regular_file(o_path)
        for o2_name, o2_path in outputs[i + 1:]:
            if same_file(o_path, o2_path):
                raise UsageError(f"{o_name} and {o2_name} name the same file ({o_path}); give two different files")
        for i_name, i_path in inputs:
            if same_file(o_path, i_path):
                raise UsageError(f"{o_name} is the same file as {i_name} ({i_path}): the output would overwrite "
                                 f"the input; choose another {o_name}")
            if (i_path.is_dir() and o_path.suffix.lower() in IMAGE_SUFFIXES and o_path.exists()
                    and Path(os.path.abspath(i_path)) in Path(os.path.abspath(o_path)).parents):
                raise UsageError(f"{o_name} ({o_path}) is an image inside the {i_name} folder: the output would "
                                 f"overwrite an input image; choose another {o_name}")
    return [p for _, p in outputs]
