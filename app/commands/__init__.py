"""Subcommands of `robocal`; each module has HELP, add_arguments(parser), run(args)."""
from __future__ import annotations

from dataclasses import dataclass, field


@dataclass
class CommandResult:
    """What a subcommand hands back: a human summary and the data printed by --json."""

    text: str = ""
    data: dict = field(default_factory=dict)
    exit_code: int = 0


def not_built(step: str, issue: int):
    """run() of a subcommand whose step is not built yet: says so plainly."""
    from core.errors import RoboCalError

    def run(args):
        raise RoboCalError(f"the {step} step is not built yet (issue {issue}); nothing was done")

    return run
