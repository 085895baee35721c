"""Atomic file writes: a failed run never leaves half a file or overwrites a good one."""
from __future__ import annotations

import json
import os
import tempfile
from pathlib import Path

import numpy as np

from core.errors import RoboCalError

_UMASK = os.umask(0)
os.umask(_UMASK)


def ensure_writable_dir(folder: str | Path) -> Path:
    """Create `folder` if needed and check that files can be written in it."""
    folder = Path(folder)
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise RoboCalError(f"cannot create the folder ({exc.strerror})", source=folder,
                           hint="Choose a folder you can write to.") from exc
    if not os.access(folder, os.W_OK | os.X_OK):
        raise RoboCalError("the folder is not writable", source=folder,
                           hint="Choose a folder you can write to.")
    return folder


def atomic_write_bytes(path: str | Path, data: bytes) -> Path:
    """Write `data` to `path` through a temporary file in the same folder and a rename."""
    path = Path(path)
    folder = ensure_writable_dir(path.parent if str(path.parent) else Path("."))
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=folder)
    try:
        with os.fdopen(fd, "wb") as handle:
            handle.write(data)
            handle.flush()
            os.fsync(handle.fileno())
        os.chmod(tmp, 0o666 & ~_UMASK)  # mkstemp makes 0600; give the file the usual mode
        os.replace(tmp, path)
    except OSError as exc:
        Path(tmp).unlink(missing_ok=True)
        raise RoboCalError(f"cannot write the file ({exc.strerror})", source=path,
                           hint="Check the disk space and permissions.") from exc
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return path


def atomic_write_text(path: str | Path, text: str) -> Path:
    return atomic_write_bytes(path, text.encode("utf-8"))


def atomic_write_many(files: dict[str | Path, bytes | str]) -> list[Path]:
    """Write several files as one: every file goes to a temporary beside its target first, and
    only when all are written (and synced) are they renamed into place. A failure while writing
    leaves every target as it was."""
    temps: list[tuple[str, Path]] = []
    try:
        for path, data in files.items():
            path = Path(path)
            folder = ensure_writable_dir(path.parent if str(path.parent) else Path("."))
            fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=folder)
            temps.append((tmp, path))
            with os.fdopen(fd, "wb") as handle:
                handle.write(data.encode("utf-8") if isinstance(data, str) else data)
                handle.flush()
                os.fsync(handle.fileno())
            os.chmod(tmp, 0o666 & ~_UMASK)
    except OSError as exc:
        for tmp, _ in temps:
            Path(tmp).unlink(missing_ok=True)
        failed = temps[-1][1] if temps else next(iter(files), "")
        raise RoboCalError(f"cannot write the file ({exc.strerror}); no output was changed", source=failed,
                           hint="Check the disk space and permissions.") from exc
    except BaseException:
        for tmp, _ in temps:
            Path(tmp).unlink(missing_ok=True)
        raise
    done: list[Path] = []
    for tmp, path in temps:        # renames in one folder: these do not run out of space
        try:
            os.replace(tmp, path)
        except OSError as exc:
            for left, _ in temps[len(done):]:
                Path(left).unlink(missing_ok=True)
            written = ", ".join(p.name for p in done) or "none"
            raise RoboCalError(f"cannot replace the file ({exc.strerror}); already replaced: {written}",
                               source=path, hint="Check the permissions.") from exc
        done.append(path)
    return done


def json_default(value):
    """`json.dumps(default=...)` for numpy arrays and scalars."""
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    raise TypeError(f"not JSON serialisable: {type(value).__name__}")


def strict_json(value):
    """Plain Python types (dicts, lists, bool, int, float) with non-finite numbers as None,
    for strict JSON."""
    if isinstance(value, dict):
        return {k: strict_json(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [strict_json(v) for v in value]
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    if isinstance(value, (int, np.integer)):
        return int(value)
    if isinstance(value, (float, np.floating)):
        return float(value) if np.isfinite(value) else None
    return value


def atomic_write_json(path: str | Path, data) -> Path:
    return atomic_write_text(path, json.dumps(data, indent=2, ensure_ascii=False, default=json_default) + "\n")


def drop_partial_last_line(path: str | Path) -> bool:
    """Cut a partly written last line (a run killed mid-write) off an append-only text file,
    so that appending goes on after the last complete line. True if there was one."""
    path = Path(path)
    try:
        if not path.exists():
            return False
        data = path.read_bytes()
        if not data or data.endswith(b"\n"):
            return False
        with open(path, "r+b") as handle:
            handle.truncate(data.rfind(b"\n") + 1)
            handle.flush()
            os.fsync(handle.fileno())
    except OSError as exc:
        raise RoboCalError(f"cannot repair the file's interrupted last line ({exc.strerror})", source=path,
                           hint="Check the file's permissions.") from exc
    return True


def read_text(path: str | Path, kind: str) -> str:
    """The text of a UTF-8 file (a byte-order mark is dropped), with one clear message for a
    missing, unreadable or binary file; `kind` names what was expected ("a JSON file")."""
    path = Path(path)
    try:
        return path.read_text(encoding="utf-8-sig")
    except FileNotFoundError as exc:
        raise RoboCalError("file not found", source=path, hint="Check the path.") from exc
    except IsADirectoryError as exc:
        raise RoboCalError("this is a folder, not a file", source=path, hint=f"Give {kind}.") from exc
    except OSError as exc:
        raise RoboCalError(f"cannot read the file ({exc.strerror})", source=path) from exc
    except UnicodeDecodeError as exc:
        raise RoboCalError("not a text file", source=path, hint=f"Give {kind}.") from exc


def read_json(path: str | Path) -> dict:
    """Read a JSON object, with a clear message for a missing or malformed file."""
    text = read_text(path, "a JSON file")
    try:
        data = json.loads(text)
    except json.JSONDecodeError as exc:
        raise RoboCalError(f"not valid JSON (line {exc.lineno}, column {exc.colno}: {exc.msg})",
                           source=path, hint="Fix the syntax or re-export the file.") from exc
    except RecursionError:
        raise RoboCalError("the JSON is nested too deeply to be a RoboCal file", source=path,
                           hint="Check that this is the right file.") from None
    except ValueError as exc:           # e.g. an integer with more digits than Python converts
        raise RoboCalError(f"not a usable JSON file ({exc})", source=path,
                           hint="Check that this is the right file.") from exc
    if not isinstance(data, dict):
        raise RoboCalError("expected a JSON object at the top level", source=path)
    return data
