"""core.locks: one writer per output, across processes, released even on kill -9."""
from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from core.errors import RoboCalError
from core.files import atomic_write_many
from core.locks import lock_path, output_lock, output_locks

ROOT = Path(__file__).resolve().parents[2]


def hold_in_child(path: Path) -> subprocess.Popen:
    code = textwrap.dedent(f"""
        import sys, time
        from core.locks import output_lock
        with output_lock({str(path)!r}):
            print("held", flush=True)
            time.sleep(60)
    """)
    child = subprocess.Popen([sys.executable, "-c", code], cwd=ROOT, stdout=subprocess.PIPE, text=True)
    assert child.stdout.readline().strip() == "held"
    return child


def test_a_second_process_is_refused_with_the_holder_and_kill_releases(tmp_path):
    out = tmp_path / "calibrated.json"
    child = hold_in_child(out)
    try:
        with pytest.raises(RoboCalError, match=f"being written by process {child.pid}"):
            with output_lock(out):
                pass
    finally:
        child.send_signal(signal.SIGKILL)
        child.wait(10)
    with output_lock(out):                      # the kernel released the dead process's lock
        assert lock_path(out).exists()
    assert not lock_path(out).exists() and not out.exists()   # nothing left, nothing created


def test_same_file_by_another_name_is_the_same_lock(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert lock_path("a.csv") == lock_path(tmp_path / "a.csv")
    assert lock_path(tmp_path / "a.csv") != lock_path(tmp_path / "b.csv")
    with output_locks([tmp_path / "a.csv", "a.csv", tmp_path / "b.csv"]) as held:
        assert held == sorted({tmp_path / "a.csv", tmp_path / "b.csv"})


def test_write_many_changes_nothing_when_one_file_fails(tmp_path):
    a, b = tmp_path / "stereo.yaml", tmp_path / "ros" / "left.yaml"
    a.write_text("old a")
    blocker = tmp_path / "blocked"
    blocker.write_text("a file where a folder is needed")
    with pytest.raises(RoboCalError, match="folder"):
        atomic_write_many({a: "new a", blocker / "right.yaml": "new b"})
    assert a.read_text() == "old a"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["blocked", "stereo.yaml"]   # no temporaries left
    assert atomic_write_many({a: "new a", b: b"new b"}) == [a, b]
    assert (a.read_text(), b.read_bytes()) == ("new a", b"new b")
    os.chmod(a, 0o644)
