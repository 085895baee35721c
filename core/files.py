"""Atomic file writes: a failed run never leaves half a file or overwrites a good one."""
from __future__ import annotations

import contextlib
import json
import os
import shutil
import stat
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


_KINDS = ((stat.S_ISDIR, "a folder"), (stat.S_ISCHR, "a device"), (stat.S_ISBLK, "a device"),
          (stat.S_ISFIFO, "a pipe (FIFO)"), (stat.S_ISSOCK, "a socket"))


def require_regular_file(path: str | Path) -> Path:
    """`path`, if it does not exist or is a regular file (a link to one counts); else one
    RoboCalError saying what is there, before anything reads, repairs or replaces it. Every
    writer calls this first: a rename would put a regular file in place of a device, a pipe
    would block a reader, and a folder cannot be appended to."""
    path = Path(path)
    try:
        mode = os.stat(path).st_mode
    except OSError:             # nothing there, or a path that cannot be: the write names the problem
        return path
    if stat.S_ISREG(mode):
        return path
    kind = next((name for test, name in _KINDS if test(mode)), "not a regular file")
    raise RoboCalError(f"this is {kind}, not a regular file; nothing was written to it", source=path,
                       hint="Give the path of a file to write (a new name, or a file RoboCal wrote).")


def atomic_write_bytes(path: str | Path, data: bytes) -> Path:
    """Write `data` to `path` through a temporary file in the same folder and a rename."""
    path = require_regular_file(path)
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
    """Write several files as one: all or none. Every file goes to a temporary beside its target
    first; a target that is a folder is refused before anything is written; only when all are
    written (and synced) are they renamed into place, each previous file kept as a hard link
    until the last rename, so a rename that fails puts back the ones already replaced."""
    targets = [Path(p) for p in files]
    for path in targets:
        if path.is_dir():
            raise RoboCalError("a folder is in the way of this output file; no output was changed", source=path,
                               hint="Remove or rename that folder, or write elsewhere.")
        require_regular_file(path)
    temps: list[tuple[str, Path]] = []
    try:
        for path, data in zip(targets, files.values()):
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
    _replace_all(temps)
    return [path for _, path in temps]


def _keep(path: Path) -> Path:
    """A hard link (a copy where links are not supported) to the file at `path`, beside it."""
    old = path.with_name(f".{path.name}.{os.getpid()}.old")
    old.unlink(missing_ok=True)
    try:
        os.link(path, old)
    except OSError:
        shutil.copy2(path, old)
    return old


def _replace_all(temps: list[tuple[str, Path]]) -> None:
    """Rename each temporary onto its target; on a failure, put back the targets already
    replaced (their previous file, or no file where there was none)."""
    kept: list[tuple[Path, Path | None]] = []          # replaced targets, and their previous file
    current = temps[0][1] if temps else None
    try:
        for tmp, path in temps:
            current, old = path, None
            if path.exists():
                old = _keep(path)
            try:
                os.replace(tmp, path)
            except BaseException:
                if old is not None:
                    old.unlink(missing_ok=True)
                raise
            kept.append((path, old))
    except BaseException as exc:
        for path, old in reversed(kept):
            with contextlib.suppress(OSError):
                if old is not None:
                    os.replace(old, path)
                else:
                    path.unlink()
        for tmp, _ in temps:
            Path(tmp).unlink(missing_ok=True)
        if isinstance(exc, OSError):
            raise RoboCalError(f"cannot replace the file ({exc.strerror}); no output was changed", source=current,
                               hint="Check the permissions.") from exc
        raise
    for _, old in kept:
        if old is not None:
            with contextlib.suppress(OSError):
                old.unlink()


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


def json_text(data) -> str:
    """The JSON text RoboCal writes (indented, UTF-8, numpy values as plain numbers)."""
    return json.dumps(data, indent=2, ensure_ascii=False, default=json_default) + "\n"


def atomic_write_json(path: str | Path, data) -> Path:
    return atomic_write_text(path, json_text(data))


def drop_partial_last_line(path: str | Path) -> bool:
    """Cut a partly written last line (a run killed mid-write) off an append-only text file,
    so that appending goes on after the last complete line. True if there was one. Call it
    only once the file is known to be the writer's own kind (its tag and header read): a file
    that is refused must come back unchanged."""
    path = require_regular_file(path)
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
