"""Subcommands of `robocal`; each module has HELP, add_arguments(parser), run(args)."""
from __future__ import annotations

import sys
from dataclasses import dataclass, field


@dataclass
class CommandResult:
    """What a subcommand hands back: a human summary and the data printed by --json."""

    text: str = ""
    data: dict = field(default_factory=dict)
    exit_code: int = 0



class ProgressLine:
    """One updating progress line on stderr when it is a terminal; silent otherwise (so pipes,
    logs and --json output stay clean). Pass it, or a `part(start, stop)` of it, as `progress`."""

    def __init__(self, command: str, stream=None):
        self.command = command
        self.stream = stream or sys.stderr
        self.active = bool(getattr(self.stream, "isatty", lambda: False)())
        self.shown = False

    def part(self, start: float, stop: float):
        return lambda fraction, message: self(start + (stop - start) * fraction, message)

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
