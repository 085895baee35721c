"""`robocal gui ARGS` in a fresh process, and the classroom demo walked in one
(`robocal gui --demo --autopilot --screenshots DIR`: ~40 s of one core).

With pytest-xdist the demo walk starts in the background as soon as a worker has collected
tests/app/test_autopilot_fresh_process.py: the controller process, idle otherwise, starts it at a
lower priority (nice 10), so it runs mostly while the test workers wait (on a robot simulator's
replies, a timer, a child process) and takes little from a worker that has work. That module is
handed out last (tests/scheduling.py) and reads the walk's result, waiting for the rest of it if
it has not ended yet. Without xdist its fixture walks the demo itself, in the foreground.

The walk's folder holds stdout.txt, stderr.txt, shots/ (its screenshots), tmp/ (its TMPDIR) and,
once the process has ended, `returncode` (its exit status, or "timed out")."""
from __future__ import annotations

import os
import subprocess
import sys
import threading
import time
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
#: the test module that reads the background walk
MODULE = "tests/app/test_autopilot_fresh_process.py"
#: the walk's folder, set by the controller process for its workers
FOLDER_ENV = "ROBOCAL_TESTS_FRESH_DEMO"
#: a whole demo walk: ~40 s alone, over 5 min on a machine busy with other work
WALK_TIMEOUT_S = 1800
BACKGROUND_NICENESS = 10


def run_gui(*args, timeout=900, **env_extra) -> subprocess.CompletedProcess:
    """`robocal gui ARGS` in a fresh process, offscreen, its output captured."""
    env = dict(os.environ, QT_QPA_PLATFORM="offscreen", **env_extra)
    return subprocess.run([sys.executable, "-m", "app.cli", "gui", *args], cwd=ROOT, env=env,
                          capture_output=True, text=True, timeout=timeout, check=False)


@dataclass
class DemoRun:
    """A finished fresh-process demo walk."""

    returncode: int | None          # None: killed after WALK_TIMEOUT_S
    stdout: str
    stderr: str
    shots: Path                     # the screenshots folder it was given
    temp: Path                      # its TMPDIR


def start_walk(folder: Path, niceness: int = 0) -> subprocess.Popen:
    """Start `gui --demo --autopilot --screenshots folder/shots` (TMPDIR folder/tmp); a thread
    writes folder/returncode when the process has ended, or kills it at WALK_TIMEOUT_S."""
    (folder / "tmp").mkdir(parents=True)
    env = dict(os.environ, QT_QPA_PLATFORM="offscreen", TMPDIR=str(folder / "tmp"))
    env.pop(FOLDER_ENV, None)
    with open(folder / "stdout.txt", "w") as out, open(folder / "stderr.txt", "w") as err:
        proc = subprocess.Popen([sys.executable, "-m", "app.cli", "gui", "--demo", "--autopilot", "--screenshots",
                                 str(folder / "shots")], cwd=ROOT, env=env, stdin=subprocess.DEVNULL,
                                stdout=out, stderr=err, text=True)
    if niceness:
        os.setpriority(os.PRIO_PROCESS, proc.pid, niceness)

    def wait():
        try:
            status = str(proc.wait(timeout=WALK_TIMEOUT_S))
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()
            status = "timed out"
        partial = folder / "returncode.part"
        partial.write_text(status)
        partial.replace(folder / "returncode")

    threading.Thread(target=wait, name="fresh demo walk", daemon=True).start()
    return proc


def walk_result(folder: Path) -> DemoRun:
    """The walk in `folder`, once it has ended (waits for it, polling its folder)."""
    done = folder / "returncode"
    deadline = time.monotonic() + WALK_TIMEOUT_S + 60
    while not done.exists():
        if time.monotonic() > deadline:
            raise TimeoutError(f"the demo walk in {folder} did not end")
        time.sleep(0.2)
    status = done.read_text()
    return DemoRun(None if status == "timed out" else int(status), (folder / "stdout.txt").read_text(),
                   (folder / "stderr.txt").read_text(), folder / "shots", folder / "tmp")


def background_folder() -> Path | None:
    """The folder of the walk the controller started in the background, if it did."""
    folder = os.environ.get(FOLDER_ENV)
    return Path(folder) if folder and (Path(folder) / "stdout.txt").exists() else None


class WalkInBackground:
    """Controller-side (pytest-xdist): starts the demo walk when a worker has collected MODULE,
    in the folder it names to the workers (FOLDER_ENV, set before they start); kills it if the
    session ends first."""

    def __init__(self, config):
        self.config = config
        self.folder: Path | None = None
        self.walk: subprocess.Popen | None = None

    def pytest_sessionstart(self, session):          # before xdist starts its workers (trylast)
        self.folder = self.config._tmp_path_factory.getbasetemp() / "fresh-demo"
        os.environ[FOLDER_ENV] = str(self.folder)

    def pytest_xdist_node_collection_finished(self, node, ids):
        if self.walk is None and any(i.startswith(MODULE + "::") for i in ids):
            self.walk = start_walk(self.folder, BACKGROUND_NICENESS)

    def pytest_sessionfinish(self, session):
        if self.walk is not None and self.walk.poll() is None:
            self.walk.kill()
            self.walk.wait()
