"""What the append-only writers (measurements, rejected poses) share: every write flushed and
fsynced so a row taken survives a crash; a failed write is one clear RoboCalError; closing after
it is quiet (the unwritten rest is dropped), so that first message is the one the user reads."""
from __future__ import annotations

import os
from pathlib import Path

from core.errors import RoboCalError


class AppendedFile:
    """Mixin: the class sets `path` and opens `_handle` (append mode)."""

    path: Path
    _handle = None
    _write_failed = False

    def _write(self, text: str) -> None:
        """Write, flush and fsync (OSError passes through: the caller is opening the file)."""
        self._handle.write(text)
        self._handle.flush()
        os.fsync(self._handle.fileno())

    def _append(self, text: str) -> None:
        """One row, on disk when this returns, or one RoboCalError naming the file."""
        try:
            self._write(text)
        except OSError as exc:
            self._write_failed = True
            raise RoboCalError(f"cannot write the file ({exc.strerror})", source=self.path,
                               hint="Check the disk space and permissions.") from exc

    def close(self) -> None:
        """Close the file; after a failed write (already reported) quietly."""
        handle, self._handle = self._handle, None
        if handle is None:
            return
        try:
            handle.close()
        except OSError as exc:
            if not self._write_failed:
                raise RoboCalError(f"cannot finish writing the file ({exc.strerror})", source=self.path,
                                   hint="Check the disk space and permissions.") from exc

    def __enter__(self):
        return self

    def __exit__(self, *exc) -> None:
        self.close()
