"""Subcommands of `robocal`; each module has HELP, add_arguments(parser), run(args)."""
from __future__ import annotations

import os
import sys
from dataclasses import dataclass, field
from pathlib import Path

from core.errors import RoboCalError, UsageError


@dataclass
class CommandResult:
    """What a subcommand hands back: a human summary and the data printed by --json."""

    text: str = ""
    data: dict = field(default_factory=dict)
    exit_code: int = 0



class ProgressLine:
    """One updating progress line on stderr when it is a terminal; silent otherwise (so pipes,
    logs and --json output stay clean). Pass it, or ``Monitor(line).sub(start, stop)``, as `progress`."""

    def __init__(self, command: str, stream=None):
        self.command = command
        self.stream = stream or sys.stderr
        self.active = bool(getattr(self.stream, "isatty", lambda: False)())
        self.shown = False

    def __call__(self, fraction: float, message: str) -> None:
        if not self.active:
            return
        self.stream.write(f"\rrobocal {self.command}: {fraction * 100:5.1f} %  {message:<50.50}")
        self.stream.flush()
        self.shown = True

    def close(self) -> None:
        if self.shown:
            self.stream.write("\n")
            self.stream.flush()


def check_output(path: str | None, what: str, folder_given: bool = False) -> None:
    """Refuse an output that cannot be written before the work starts (nothing is created).
    `folder_given`: `path` is a file the command names inside the folder the user gave."""
    if not path:
        return
    p = Path(path)
    if p.is_dir() and folder_given:
        raise RoboCalError("a folder is in the way of this output file", source=path,
                           hint=f"Remove or rename that folder, or give another {what} folder.")
    if p.is_dir():
        raise UsageError(f"{what} '{path}' is a folder; give a file name")
    existing = p.parent if str(p.parent) else Path(".")
    while not existing.exists() and existing != existing.parent:
        existing = existing.parent
    if existing.is_file():
        raise RoboCalError(f"cannot write here: {existing} is a file, not a folder", source=path,
                           hint=f"Choose another {what} path.")
    if not os.access(existing, os.W_OK | os.X_OK):
        raise RoboCalError(f"cannot write here: {existing} is not writable", source=path,
                           hint=f"Choose another {what} path.")
