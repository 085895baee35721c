"""Every `robocal …` command line in docs/*.md is one the command line accepts.

Every line must parse with the real parser, except a mention of a command by name
(`robocal measure`, `robocal locate/measure --marker`), which must name real subcommands and options.
Placeholders are read as values: `[...]` optional parts are kept, `a|b|c` is tried with each
alternative, a lone `N` is a number. The cheap exercise lines run for real on the virtual lab.
"""
from __future__ import annotations

import argparse
import contextlib
import io
import json
import re
import shlex
from pathlib import Path

import pytest

from app.cli import build_parser, main

DOCS = Path(__file__).resolve().parents[1] / "docs"
INLINE = re.compile(r"`((?:\.venv/bin/)?robocal(?: [^`]*)?)`")
FENCE = re.compile(r"```[a-z]*\n(.*?)```", re.S)
PLACEHOLDER_NUMBER = {"N": "3"}


def command_lines() -> list[tuple[str, str]]:
    """(file name, command line) for every robocal command line in docs/*.md."""
    out = []
    for md in sorted(DOCS.glob("*.md")):
        text = md.read_text(encoding="utf-8")
        lines = [m.group(1) for m in INLINE.finditer(text)]
        for block in FENCE.findall(text):
            lines += [ln.strip() for ln in block.replace("\\\n", " ").splitlines() if ln.strip().startswith("robocal ")]
        out += [(md.name, re.sub(r"^\.venv/bin/", "", ln).strip()) for ln in lines]
    return out


LINES = command_lines()


def _subparsers() -> dict[str, argparse.ArgumentParser]:
    parser = build_parser()
    action = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return dict(action.choices)


SUB = _subparsers()


def _variants(line: str) -> list[list[str]]:
    """The line's tokens with placeholders filled, one list per `a|b` alternative."""
    tokens = shlex.split(line.replace("[", " ").replace("]", " ").replace("\\|", "|"))[1:]
    out = [[]]
    for tok in tokens:
        options = tok.split("|") if "|" in tok and not tok.startswith("-") else [tok]
        out = [v + [PLACEHOLDER_NUMBER.get(o, o)] for v in out for o in options]
    return out


def test_the_docs_have_command_lines_to_check():
    names = {name for name, _ in LINES}
    assert {"teaching-guide.md", "user-guide.md"} <= names
    assert any("select-poses" in ln and "--out" in ln for _, ln in LINES)


@pytest.mark.parametrize("doc, line", LINES, ids=[f"{n}:{ln[:50]}" for n, ln in LINES])
def test_command_line_parses(doc, line):
    for tokens in _variants(line):
        if not tokens:                                               # `robocal` alone: the wizard
            continue
        if tokens[0].startswith("-"):                                # `robocal --help`
            with contextlib.redirect_stdout(io.StringIO()), pytest.raises(SystemExit) as done:
                build_parser().parse_args(tokens)
            assert done.value.code == 0, f"{doc}: {line}"
            continue
        commands = tokens[0].split("/")
        for command in commands:
            assert command in SUB, f"{doc}: `{line}` names no subcommand {command!r}"
            sub = SUB[command]
            known = {s for a in sub._actions for s in a.option_strings}
            used = {t.split("=")[0] for t in tokens[1:] if t.startswith("--")}
            assert used <= known, f"{doc}: `{line}`: {command} has no option {sorted(used - known)}"
        if len(commands) > 1 or len(tokens) == 1:                   # a mention: `robocal measure`
            continue
        with contextlib.redirect_stderr(io.StringIO()) as err:
            try:
                SUB[commands[0]].parse_args(tokens[1:])
            except SystemExit as exc:
                pytest.fail(f"{doc}: `{line}` does not parse (exit {exc.code}): {err.getvalue().strip()}")


def test_incomplete_lines_are_caught():
    """The check above fails for a line missing a required option or naming a wrong one."""
    sub = SUB["select-poses"]
    with contextlib.redirect_stderr(io.StringIO()), pytest.raises(SystemExit):
        sub.parse_args(["--robot", "R.json", "--count", "3", "--json"])           # no --out
    known = {s for a in sub._actions for s in a.option_strings}
    assert "--noise" not in known and "--out" in known


def test_select_poses_exercise_runs_as_written(tmp_path, monkeypatch):
    """The teaching guide's select-poses line, for real on the virtual lab."""
    line = next(ln for doc, ln in LINES if doc == "teaching-guide.md" and ln.startswith("robocal select-poses"))
    monkeypatch.chdir(tmp_path)
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        assert main(shlex.split(line)[1:]) == 0
    data = json.loads(out.getvalue())
    assert (tmp_path / "poses.csv").is_file() and data["count"] == 30
    assert data["indices"]["O5"] > data["random_median"]["O5"]        # better than random poses


def test_the_teaching_guide_blocks_run_from_an_empty_folder():
    """Every file a command of the guide's code blocks reads is written by an earlier command
    of the blocks (or is a preset robot named by its name): the blocks run, in order, from an
    empty folder — what `python -m bench teaching` does for real."""
    from app.commands.paths import declared
    from bench.bench_teaching import guide_commands
    from core.robot.model import preset_names

    lines = guide_commands()
    assert len(lines) >= 30 and all(ln in {l for d, l in LINES if d == "teaching-guide.md"} for ln in lines)
    written: list[Path] = []
    for line in lines:
        tokens = shlex.split(line)[1:]
        args = SUB[tokens[0]].parse_args(tokens[1:])
        module = __import__(f"app.commands.{tokens[0].replace('-', '_')}", fromlist=["INPUTS"])
        for option, path in declared(args, getattr(module, "INPUTS", ())):
            if option in ("--robot", "--lab-robot", "--nominal") and str(path) in preset_names():
                continue
            if option == "--frame" and str(path) in ("base", "camera", "measurement"):    # a frame, not a file
                continue
            assert not path.is_absolute() and ".." not in path.parts, f"`{line}`: {option} {path} is not local"
            assert any(path == w or w in path.parents for w in written), \
                f"`{line}`: {option} {path} is written by no earlier command of the guide"
        written += [path for _, path in declared(args, getattr(module, "OUTPUTS", ()))]
    assert not any("--pairs 12" in ln for ln in lines)                  # the coverage check warns below 20


def test_the_teaching_guide_stereo_run_does_not_warn(tmp_path, monkeypatch, capsys):
    """The guide's --pairs gives a stereo calibration without the 'not enough views' warning."""
    from bench.bench_teaching import guide_commands
    lines = guide_commands()
    simulate = next(ln for ln in lines if ln.startswith("robocal simulate --out lab "))
    pairs = shlex.split(simulate)[shlex.split(simulate).index("--pairs") + 1]
    monkeypatch.chdir(tmp_path)
    assert main(["simulate", "--out", "lab", "--seed", "7", "--pairs", pairs, "--poses", "0"]) == 0
    stereo = next(ln for ln in lines if ln.startswith("robocal stereo-calibrate"))
    capsys.readouterr()
    assert main(shlex.split(stereo)[1:]) == 0
    out = capsys.readouterr()
    assert "not enough views" not in out.out + out.err and (tmp_path / "lab" / "stereo.yaml").is_file()
