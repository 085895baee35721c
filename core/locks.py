"""Advisory output locks: two runs that write the same file never interleave.

``with output_lock(path): ...`` holds an exclusive `fcntl.flock` on a lock file named after the
absolute path of `path`, in a per-user folder of the system's temporary directory (nothing is
created beside the output, which may not exist yet). The kernel releases the lock when the
process ends, even on kill -9, so a crashed run never leaves a file locked. A second writer
gets one clear message naming the process that holds the file. The lock file is removed on
release (re-checked on acquire, so a lock file unlinked by another release is never trusted).
"""
from __future__ import annotations

import contextlib
import fcntl
import hashlib
import os
import tempfile
from pathlib import Path
from typing import Iterable, Iterator

from core.errors import RoboCalError


def lock_path(path: str | Path) -> Path:
    """The lock file of `path` (same absolute path, same lock file)."""
    key = hashlib.sha1(os.path.abspath(path).encode("utf-8", "surrogateescape")).hexdigest()[:24]
    return Path(tempfile.gettempdir()) / f"robocal-locks-{os.getuid()}" / f"{key}.lock"


def _holder(fd: int) -> str:
    try:
        os.lseek(fd, 0, os.SEEK_SET)
        pid = os.read(fd, 32).decode("ascii", "replace").strip()
    except OSError:
        pid = ""
    return pid if pid.isdigit() else "another process"


@contextlib.contextmanager
def output_lock(path: str | Path) -> Iterator[Path]:
    """Hold the write lock of `path` for the `with` block; RoboCalError if another process has it."""
    path = Path(path)
    lock = lock_path(path)
    try:
        lock.parent.mkdir(mode=0o700, exist_ok=True)
    except OSError as exc:
        raise RoboCalError(f"cannot create the lock folder ({exc.strerror})", source=lock.parent,
                           hint="Check the temporary folder (TMPDIR).") from exc
    while True:
        try:
            fd = os.open(lock, os.O_RDWR | os.O_CREAT, 0o644)
        except OSError as exc:
            raise RoboCalError(f"cannot create the lock file ({exc.strerror})", source=lock,
                               hint="Check that the folder exists and is writable.") from exc
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            holder = _holder(fd)
            os.close(fd)
            who = f"process {holder}" if holder.isdigit() else holder
            raise RoboCalError(f"the file is being written by {who}", source=path,
                               hint="Wait for that run to end, or write to another file.") from None
        try:
            same = os.fstat(fd).st_ino == os.stat(lock).st_ino
        except FileNotFoundError:
            same = False
        if same:
            break
        os.close(fd)                      # the lock file was removed by its last holder: retry
    try:
        os.ftruncate(fd, 0)
        os.write(fd, f"{os.getpid()}\n".encode("ascii"))
        yield path
    finally:
        with contextlib.suppress(OSError):
            os.unlink(lock)
        os.close(fd)


@contextlib.contextmanager
def output_locks(paths: Iterable[str | Path]) -> Iterator[list[Path]]:
    """Hold the locks of several outputs (taken in a fixed order, so two runs cannot deadlock)."""
    unique = sorted({Path(os.path.abspath(p)) for p in paths})
    with contextlib.ExitStack() as stack:
        for p in unique:
            stack.enter_context(output_lock(p))
        yield unique
