"""The `robocal` command line: one subcommand per wizard step (DESIGN.md).

Exit codes: 0 success, 2 usage error, 1 bad data — with one clear line on stderr, never a
traceback. `--json` prints the command's result as one JSON object on stdout.
Each subcommand lives in app/commands/<name>.py and provides HELP, add_arguments(parser)
and run(args) -> CommandResult.
"""
from __future__ import annotations

import argparse
import importlib
import json
import sys

from app.commands import CommandResult
from core.errors import Cancelled, RoboCalError, UsageError
from core.files import json_default

COMMANDS = {
    "gui": "gui",
    "simulate": "simulate",
    "stereo-calibrate": "stereo_calibrate",
    "locate": "locate",
    "measure": "measure",
    "select-poses": "select_poses",
    "identify": "identify",
    "evaluate": "evaluate",
    "export": "export",
    "sim-robot": "sim_robot",
}


class _Parser(argparse.ArgumentParser):
    """argparse with a one-line usage error and exit code 2."""

    def error(self, message: str):  # noqa: D401 - argparse API
        sys.stderr.write(f"{self.prog}: error: {message} (see `{self.prog} --help`)\n")
        raise SystemExit(2)


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="robocal", description="Robot calibration with a stereo camera pair.")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    for name, module_name in COMMANDS.items():
        module = importlib.import_module(f"app.commands.{module_name}")
        p = sub.add_parser(name, help=module.HELP, description=module.HELP)
        module.add_arguments(p)
        if name != "gui":
            p.add_argument("--json", action="store_true", help="print the result as one JSON object on stdout")
        p.set_defaults(_module=module)
    return parser


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    parser = build_parser()
    if not argv:
        argv = ["gui"]
    try:
        args = parser.parse_args(argv)
    except SystemExit as exc:
        return int(exc.code or 0)
    try:
        result: CommandResult = args._module.run(args)
    except UsageError as exc:
        sys.stderr.write(f"robocal {args.command}: error: {exc.message}\n")
        return 2
    except RoboCalError as exc:
        sys.stderr.write(f"robocal {args.command}: {exc.message}\n")
        return 1
    except Cancelled:
        sys.stderr.write(f"robocal {args.command}: cancelled\n")
        return 1
    except KeyboardInterrupt:
        sys.stderr.write(f"robocal {args.command}: interrupted\n")
        return 130
    except Exception as exc:  # last resort: one line, never a traceback
        sys.stderr.write(f"robocal {args.command}: internal error: {type(exc).__name__}: {exc} "
                         f"(please report it)\n")
        return 1
    if result is None:
        return 0
    if getattr(args, "json", False):
        sys.stdout.write(json.dumps(result.data, default=json_default) + "\n")
    elif result.text:
        sys.stdout.write(result.text.rstrip("\n") + "\n")
    return result.exit_code


if __name__ == "__main__":
    sys.exit(main())
