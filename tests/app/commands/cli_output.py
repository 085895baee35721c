"""A `robocal` command run in the test's own process, with what it printed read back."""
from __future__ import annotations

import json

from app.cli import main


def run_json(capsys, argv: list[str]):
    """`robocal ARGV --json`: (exit code, the printed JSON or None when nothing was printed, stderr)."""
    code = main(argv + ["--json"])
    out, err = capsys.readouterr()
    return code, (json.loads(out) if out.strip() else None), err


def one_line(capsys) -> str:
    """The one line the command wrote to stderr (no traceback, no internal error)."""
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1, err
    assert "internal error" not in err[0] and "Traceback" not in err[0]
    return err[0]
