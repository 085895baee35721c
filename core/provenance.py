"""Which input files a step's output was made from, so that an output made from older inputs is
seen as out of date.

Beside an output `<stem>.<ext>` a side file `<stem>.inputs.json` (format robocal.inputs/1) records
the SHA-256 of every input file (None: the input did not exist) at the time the output was made:

    record_inputs(project / "marker.npz", {"stereo.yaml": project / "stereo.yaml"})
    changed_inputs(project / "marker.npz", {"stereo.yaml": project / "stereo.yaml"})   # -> ["stereo.yaml"]

An output without a side file (made by an older RoboCal, or by hand) is never called out of date:
nothing is known about its inputs.
"""
from __future__ import annotations

import hashlib
from pathlib import Path

from core.errors import RoboCalError
from core.files import atomic_write_json, read_json

FORMAT = "robocal.inputs/1"
SUFFIX = ".inputs.json"

_digests: dict[tuple[str, int, int], str] = {}     # (path, size, mtime ns) -> SHA-256, one entry per file


def inputs_file(output: str | Path) -> Path:
    """The side file of `output`: `<stem>.inputs.json` beside it."""
    output = Path(output)
    return output.with_name(output.stem + SUFFIX)


def digest(path: str | Path) -> str | None:
    """SHA-256 (hex) of the file's bytes, None if it does not exist. Cached by size and
    modification time, so asking again for an unchanged file does not read it again."""
    path = Path(path)
    try:
        st = path.stat()
    except OSError:
        return None
    if not path.is_file():
        return None
    key = (str(path.resolve()), st.st_size, st.st_mtime_ns)
    cached = _digests.get(key)
    if cached is None:
        h = hashlib.sha256()
        with open(path, "rb") as f:
            for block in iter(lambda: f.read(1 << 20), b""):
                h.update(block)
        cached = h.hexdigest()
        for old in [k for k in _digests if k[0] == key[0]]:
            del _digests[old]
        _digests[key] = cached
    return cached


def fingerprint(inputs: dict[str, str | Path]) -> dict[str, str | None]:
    """{name: SHA-256 or None} of the named input files now."""
    return {name: digest(path) for name, path in inputs.items()}


def record_inputs(output: str | Path, inputs: dict[str, str | Path] | dict[str, str | None], *,
                  hashed: bool = False) -> Path:
    """Write `output`'s side file (atomic) recording its inputs: file paths by name, or with
    `hashed=True` digests already taken (the inputs as they were when the work started)."""
    digests = dict(inputs) if hashed else fingerprint(inputs)
    return atomic_write_json(inputs_file(output), {"format": FORMAT, "output": Path(output).name,
                                                   "inputs": digests})


def forget_inputs(output: str | Path) -> None:
    """Remove `output`'s side file (its output was replaced by one made without a record)."""
    side = inputs_file(output)
    try:
        side.unlink(missing_ok=True)
    except OSError as exc:
        raise RoboCalError(f"cannot remove the record of the old file's inputs ({exc.strerror})", source=side,
                           hint="Check the folder's permissions, or delete the file.") from exc


def recorded_inputs(output: str | Path) -> dict[str, str | None] | None:
    """The digests recorded beside `output`, None when there is no readable side file."""
    side = inputs_file(output)
    if not side.is_file():
        return None
    try:
        data = read_json(side)
    except RoboCalError:
        return None
    if data.get("format") != FORMAT or not isinstance(data.get("inputs"), dict):
        return None
    return data["inputs"]


def changed_since(recorded: dict[str, str | None] | None, inputs: dict[str, str | Path]) -> list[str]:
    """Names of the `inputs` whose file now differs from the `recorded` digests (a name not
    recorded is not compared); [] when nothing was recorded."""
    if not recorded:
        return []
    return [name for name, path in inputs.items() if name in recorded and digest(path) != recorded[name]]


def changed_inputs(output: str | Path, inputs: dict[str, str | Path]) -> list[str]:
    """Names of the inputs that changed since `output` was made from them ([] when the output or
    its side file is missing)."""
    if not Path(output).is_file():
        return []
    return changed_since(recorded_inputs(output), inputs)
