"""The command line never shows a traceback and never overwrites what it reads: two runs into one
output, a closed / full / broken stdout, Ctrl-C at start-up. Outputs that are inputs:
tests/app/commands/test_paths.py."""
from __future__ import annotations

import os
import resource
import subprocess
import sys
from pathlib import Path

import pytest

import app.cli as cli
from app.cli import main
from core.locks import output_lock

ROOT = Path(__file__).resolve().parents[2]
ROBOT = ROOT / "resources" / "robots" / "ur5.json"


def run_shell(cmd: str, tmp_path: Path) -> subprocess.CompletedProcess:
    """Run `robocal` under bash (for redirections); stderr captured."""
    return subprocess.run(["bash", "-c", cmd], cwd=tmp_path, capture_output=True, text=True, timeout=120,
                          env={"PATH": "/usr/bin:/bin", "PYTHONPATH": str(ROOT), "HOME": str(tmp_path),
                               "PYTHONDONTWRITEBYTECODE": "1"})


ROBOCAL = f"{sys.executable} -m app.cli"


def test_a_second_writer_of_the_same_output_is_refused(tmp_path, capsys):
    out = tmp_path / "dh.csv"
    with output_lock(out):
        assert main(["export", "--robot", str(ROBOT), "--format", "dh-csv", "--out", str(out)]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "being written by process" in err[0] and str(out) in err[0]
    assert not out.exists()
    assert main(["export", "--robot", str(ROBOT), "--format", "dh-csv", "--out", str(out)]) == 0
    assert out.exists()


@pytest.mark.parametrize("redirect, expected", [
    (">/dev/full", "cannot print the result (No space left on device)"),
    (">&-", "standard output is closed"),
])
def test_stdout_full_or_closed_is_one_line(redirect, expected, tmp_path):
    proc = run_shell(f"{ROBOCAL} export --robot {ROBOT} --format dh-csv --out {tmp_path}/dh.csv "
                     f"{redirect}", tmp_path)
    lines = proc.stderr.strip().splitlines()
    assert proc.returncode == 1 and len(lines) == 1 and expected in lines[0], proc.stderr
    assert (tmp_path / "dh.csv").exists()          # the work itself was done


def test_a_closed_pipe_is_one_line(tmp_path):
    err = tmp_path / "err.txt"
    proc = run_shell(f"set -o pipefail; {ROBOCAL} export --robot {ROBOT} --format dh-csv "
                     f"--out {tmp_path}/dh.csv --json 2>{err} | (exec 0<&-; true)", tmp_path)
    text = err.read_text()
    assert "Traceback" not in text and len(text.strip().splitlines()) <= 1, text
    assert proc.returncode in (0, 1)               # 1 when the write met the closed pipe


def test_ctrl_c_while_starting_is_one_line_and_exit_130(monkeypatch, capsys):
    def interrupted(command=None):
        raise KeyboardInterrupt
    monkeypatch.setattr(cli, "build_parser", interrupted)
    assert main(["identify", "--robot", "r.json"]) == 130
    assert capsys.readouterr().err == "robocal identify: interrupted\n"


@pytest.fixture(scope="module")
def marker_ds(tmp_path_factory):
    from tests.app.virtual_inputs import marker_dataset
    return marker_dataset(tmp_path_factory.mktemp("robust_ds"), poses=6)


def _measure(ds, out, *more):
    return ["measure", "--stereo", str(ds / "stereo.yaml"), "--marker", str(ds / "marker" / "training.png"),
            "--images", str(ds / "poses"), "--joints", str(ds / "poses" / "joints.csv"), "--out", str(out), *more]


@pytest.mark.parametrize("previous", [None, b"# robocal.measurements/1\npose,target,q1\n"])
def test_a_full_disk_during_measure_is_one_line_naming_the_output(marker_ds, tmp_path, previous):
    """The measurements file meets a full disk after its first rows (a file size limit in the child,
    RLIMIT_FSIZE): one line naming the output, exit 1, the previous file as it was, nothing left."""
    out = tmp_path / "m.csv"
    if previous is not None:
        out.write_bytes(previous)
    more = ["--overwrite"] if previous is not None else []
    def limit():                          # the tag line, the header and a row fit; the next row does not
        resource.setrlimit(resource.RLIMIT_FSIZE, (300, 300))

    proc = subprocess.run([sys.executable, "-m", "app.cli", *_measure(marker_ds, out, *more)], cwd=tmp_path,
                          capture_output=True, text=True, timeout=120, preexec_fn=limit,
                          env={"PATH": "/usr/bin:/bin", "PYTHONPATH": str(ROOT), "PYTHONDONTWRITEBYTECODE": "1"})
    lines = proc.stderr.strip().splitlines()
    assert proc.returncode == 1 and len(lines) == 1, proc.stderr
    assert lines[0] == (f"robocal measure: {out}: cannot write the file (File too large). Check the disk space "
                        f"and permissions. The previous file is unchanged.")
    assert sorted(p.name for p in tmp_path.iterdir()) == (["m.csv"] if previous is not None else [])
    if previous is not None:
        assert out.read_bytes() == previous


def test_a_second_measure_into_the_same_output_is_refused(marker_ds, tmp_path, capsys):
    out = tmp_path / "m.csv"
    with output_lock(out):
        assert main(_measure(marker_ds, out)) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and f"{out}: the file is being written by process {os.getpid()}" in err[0], err
    assert list(tmp_path.iterdir()) == []
