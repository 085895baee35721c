"""Errors that reach the user as one clear line: which file, which field, what to do."""
from __future__ import annotations

from pathlib import Path


class RoboCalError(Exception):
    """Bad data or a failed step. The message is complete and shown to the user as is.

    `source` is the file (or image, or device) concerned, `field` the entry in it, and
    `hint` what the user should do about it.
    """

    def __init__(self, problem: str, *, source: str | Path | None = None,
                 field: str | None = None, hint: str | None = None):
        self.problem = problem
        self.source = str(source) if source is not None else None
        self.field = field
        self.hint = hint
        super().__init__(self.message)

    @property
    def message(self) -> str:
        where = ""
        if self.source and self.field:
            where = f"{self.source}: field '{self.field}': "
        elif self.source:
            where = f"{self.source}: "
        elif self.field:
            where = f"field '{self.field}': "
        text = where + self.problem
        if self.hint:
            text = text.rstrip(".") + ". " + self.hint
        return text


class UsageError(RoboCalError):
    """The command or call was used wrongly (command line exit code 2)."""


class Cancelled(Exception):
    """Raised inside long work when the user pressed Cancel."""
