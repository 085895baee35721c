"""The `robocal` command line: one subcommand per wizard step (DESIGN.md).

Exit codes: 0 success, 2 usage error, 1 bad data, 130 interrupted — with one clear line on
stderr, never a traceback (also when stdout is closed, full or a closed pipe, or Ctrl-C comes
during start-up). `--json` prints the command's result as one JSON object on stdout.
Each subcommand lives in app/commands/<name>.py and provides HELP, add_arguments(parser),
run(args) -> CommandResult, and optionally INPUTS / OUTPUTS (app/commands/paths.py): outputs
that would overwrite an input are refused, and outputs are locked while the command runs.

Only the standard library is imported at module level, so that even an interrupt while numpy
or OpenCV load ends in one line.
"""
from __future__ import annotations

import argparse
import importlib
import json
import os
import sys
import warnings

COMMANDS = {
    "gui": "gui",
    "simulate": "simulate",
    "stereo-calibrate": "stereo_calibrate",
    "stereo-import": "stereo_import",
    "locate": "locate",
    "locate-fixture": "locate_fixture",
    "measure": "measure",
    "select-poses": "select_poses",
    "identify": "identify",
    "evaluate": "evaluate",
    "export": "export",
    "import-measurements": "import_measurements",
    "robot-import": "robot_import",
    "sim-robot": "sim_robot",
    "report": "report",
    "check": "check",
    "reidentify": "reidentify",
    "identify-tool": "identify_tool",
    "robustness": "robustness",
    "compensate": "compensate",
    "grade": "grade",
}


def one_line(text: str) -> str:
    """`text` as one printable line: control characters and line separators (which a file's
    contents may carry into a message) are shown escaped."""
    return "".join(c if c.isprintable() else repr(c)[1:-1] for c in text.rstrip("\n"))


def say(line: str) -> None:
    """One line on stderr; silent if stderr itself is closed or broken."""
    stream = sys.stderr
    if stream is None:
        return
    try:
        stream.write(one_line(line) + "\n")
        stream.flush()
    except (OSError, ValueError):
        pass


class _Parser(argparse.ArgumentParser):
    """argparse with a one-line usage error and exit code 2."""

    def error(self, message: str):  # noqa: D401 - argparse API
        say(f"{self.prog}: error: {message} (see `{self.prog} --help`)")
        raise SystemExit(2)

    def _print_message(self, message, file=None):      # --help to a closed or full stdout
        try:
            super()._print_message(message, file)
        except (OSError, ValueError, AttributeError):
            pass


def build_parser(command: str | None = None) -> argparse.ArgumentParser:
    """The `robocal` parser; with `command` (a name in COMMANDS) only that subcommand is added,
    and only its module imported: a command line that starts with it parses the same (same
    namespace, same messages and exit codes), without building the other subcommands' parsers."""
    parser = _Parser(prog="robocal", description="Robot calibration with a stereo camera pair.")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    for name, module_name in COMMANDS.items():
        if command is not None and name != command:
            continue
        module = importlib.import_module(f"app.commands.{module_name}")
        p = sub.add_parser(name, help=module.HELP, description=module.HELP)
        module.add_arguments(p)
        if name != "gui":
            p.add_argument("--json", action="store_true", help="print the result as one JSON object on stdout")
        p.set_defaults(_module=module)
    return parser


def _print_result(command: str, text: str) -> int:
    """Print the result on stdout; a closed, full or broken stdout is one line on stderr, exit 1."""
    stream = sys.stdout
    if stream is None:
        say(f"robocal {command}: cannot print the result: standard output is closed")
        return 1
    try:
        stream.write(text)
        stream.flush()
    except BrokenPipeError:
        _silence_stdout()
        say(f"robocal {command}: the reader of the output went away (broken pipe); the result was not printed")
        return 1
    except OSError as exc:
        _silence_stdout()
        say(f"robocal {command}: cannot print the result ({exc.strerror or exc})")
        return 1
    return 0


def _silence_stdout() -> None:
    """Point stdout at /dev/null so that Python's flush at exit does not fail a second time."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        os.close(devnull)
    except (OSError, ValueError, AttributeError):
        pass


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    try:
        return _main(argv)
    except KeyboardInterrupt:
        command = (argv[0] if argv else "gui") if not (argv and argv[0].startswith("-")) else ""
        say(f"robocal {command}: interrupted" if command else "robocal: interrupted")
        return 130


def _main(argv: list[str]) -> int:
    os.environ.setdefault("OPENCV_LOG_LEVEL", "ERROR")
    from app.commands.paths import check_overlaps
    from core.errors import Cancelled, RoboCalError, UsageError
    from core.files import json_default
    from core.locks import output_locks

    if not argv:
        argv = ["gui"]
    # `gui` keeps the full parser: the window starts with every command module loaded, as before
    parser = build_parser(argv[0] if argv[0] in COMMANDS and argv[0] != "gui" else None)
    try:
        args = parser.parse_args(argv)
    except SystemExit as exc:
        return int(exc.code or 0)
    if args.command is None:
        parser.print_help()
        return 2
    try:
        outputs = check_overlaps(args, args._module)
        with output_locks(outputs), warnings.catch_warnings():
            # numerical warnings on bad data end in a clear RoboCalError or are harmless: never printed
            warnings.simplefilter("ignore")
            result = args._module.run(args)
    except UsageError as exc:
        say(f"robocal {args.command}: error: {exc.message}")
        return 2
    except RoboCalError as exc:
        say(f"robocal {args.command}: {exc.message}")
        return 1
    except Cancelled:
        say(f"robocal {args.command}: cancelled")
        return 1
    except MemoryError:
        say(f"robocal {args.command}: not enough memory for this input; give a smaller one")
        return 1
    except Exception as exc:  # noqa: BLE001 - last resort: one line, never a traceback
        say(f"robocal {args.command}: internal error: {type(exc).__name__}: {exc} (please report it)")
        return 1
    if result is None:
        return 0
    if getattr(args, "json", False):
        text = json.dumps(result.data, default=json_default) + "\n"
    else:
        text = result.text.rstrip("\n") + "\n" if result.text else ""
    if text and _print_result(args.command, text):
        return 1
    return result.exit_code


if __name__ == "__main__":
    sys.exit(main())
