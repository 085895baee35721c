"""`robocal check --port --cameras`: an unattended check of a connected cell. The robot is `robocal
sim-robot` on a real pseudo-terminal (seed 0: the virtual lab's true robot); the cameras are two
image folders holding the pairs the lab renders at the check poses (read with the camera code
the Setup page uses). A robot fault stops the check with what was measured in the log, exit 1.
The robot's motion is confirmed: asked once on a terminal, or --cell-clear; with neither (no
terminal) the check is refused (exit 2) and the robot never moves."""
from __future__ import annotations

import json
import os
import pty
import shutil
import subprocess
import sys
from pathlib import Path

import cv2
import numpy as np
import pytest

from app.cli import main
from app.lab import ideal_lab_measurements
from core.identification.file import write_calibrated_model
from core.identification.solver import identify
from core.monitoring.log import read_check_log
from core.poses.file import read_poses
from core.robot.controller_sim import ControllerSim
from core.virtual_lab.changes import apply_change
from tests.app.virtual_inputs import true_stereo_yaml

ROOT = Path(__file__).resolve().parents[3]


@pytest.fixture(scope="module")
def cell(tmp_path_factory, built_lab):
    """(folder, lab, calibrated.json, stereo.yaml, training.png, check poses file)."""
    root = tmp_path_factory.mktemp("checkport")
    lab = built_lab(None, 0, 0.5)
    write_calibrated_model(identify(lab.nominal_robot, ideal_lab_measurements(lab, 50, sigma_mm=0.05, seed=4)),
                           root / "calibrated.json")
    true_stereo_yaml(lab, root / "stereo.yaml")
    cv2.imwrite(str(root / "training.png"), lab.render_training_image())
    assert main(["check", "--robot", str(root / "calibrated.json"), "--propose-poses", str(root / "poses.csv"),
                 "--stereo", str(root / "stereo.yaml")]) == 0
    return root, lab


def render_cameras(lab, root, folder, change=None):
    """The lab's pairs at the check poses (after `change` to its true robot) as two image folders."""
    Q = read_poses(root / "poses.csv", lab.nominal_robot).Q
    true = lab.true_robot
    if change:
        apply_change(lab, change, seed=0)
    rng = np.random.default_rng(5)
    try:
        for side in ("left", "right"):
            (folder / side).mkdir(parents=True)
        for k, q in enumerate(Q):
            left, right = lab.render_marker_pair(q, rng)
            cv2.imwrite(str(folder / "left" / f"{k:03d}.png"), left)
            cv2.imwrite(str(folder / "right" / f"{k:03d}.png"), right)
    finally:
        lab.true_robot = true
    return folder


@pytest.fixture(scope="module")
def rendered(cell, tmp_path_factory):
    """rendered(change): the two camera folders of `render_cameras` for that change, rendered once
    per module (the pairs follow from the module's lab, the check poses, the change and a fixed
    seed only); tests get copies (`cameras`), so none can change what another reads."""
    root, lab = cell
    folders = {}

    def folder(change):
        if change not in folders:
            folders[change] = render_cameras(lab, root, tmp_path_factory.mktemp("rendered") / "cams", change)
        return folders[change]
    return folder


def cameras(rendered, folder, change=None):
    """--cameras LEFT,RIGHT: a copy, in `folder`, of the pairs rendered at the check poses."""
    shutil.copytree(rendered(change), folder)
    return f"{folder / 'left'},{folder / 'right'}"


def sim_robot(tmp_path, faults=""):
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    proc = subprocess.Popen([sys.executable, "-m", "app.cli", "sim-robot", "--seed", "0", "--time-scale", "0.01",
                             "--duration", "300"] + (["--faults", faults] if faults else []), cwd=tmp_path, env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    port = proc.stdout.readline().strip()
    if not port.startswith("/dev/"):
        proc.kill()
        pytest.fail(f"sim-robot printed no device: {port!r} {proc.stderr.read()}")
    return proc, port


def check_argv(root, port, cams, log):
    return ["check", "--robot", str(root / "calibrated.json"), "--log", str(log), "--port", port,
            "--profile", "robocal_v1", "--cameras", cams, "--stereo", str(root / "stereo.yaml"),
            "--marker", str(root / "training.png"), "--poses", str(root / "poses.csv")]


def check(root, port, cams, log, capsys, extra=()):
    code = main(check_argv(root, port, cams, log) + ["--json", "--cell-clear", *extra])
    out, err = capsys.readouterr()
    return code, (json.loads(out) if out.strip() else None), err


def robocal(argv, stdin):
    """`robocal ARGV` in its own process, its standard input `stdin` (a terminal or not)."""
    return subprocess.run([sys.executable, "-m", "app.cli", *argv], stdin=stdin, capture_output=True, text=True,
                          env=dict(os.environ, PYTHONPATH=str(ROOT)), timeout=600)


@pytest.mark.parametrize("change, code, kind", [(None, 0, "none"), ("tool:1.5", 3, "tool")])
def test_a_check_drives_the_serial_robot_and_says_so(cell, rendered, tmp_path, capsys, change, code, kind):
    root, lab = cell
    cams = cameras(rendered, tmp_path / "cams", change)
    proc, port = sim_robot(tmp_path)
    try:
        got, data, err = check(root, port, cams, tmp_path / "c.csv", capsys,
                               ["--reid-poses", str(tmp_path / "reid.csv")])
    finally:
        proc.terminate()
        out, _ = proc.communicate(timeout=20)
    assert got == code, err
    assert data["change"] == kind and data["measured_on"].startswith(f"serial robot on {port} (RoboCal serial protocol v1), cameras ")
    assert len(data["poses"]) == 8
    assert (tmp_path / "reid.csv").exists() == (kind == "tool")
    logged = read_check_log(tmp_path / "c.csv").checks
    assert len(logged) == 1 and logged[0].finished and len(logged[0].points) == 8
    np.testing.assert_allclose([p.q_file for p in logged[0].points],
                               read_poses(root / "poses.csv").q_file, atol=2e-3)      # as the controller reported


def test_a_robot_fault_stops_the_check_with_the_log_kept(cell, rendered, tmp_path, capsys):
    root, lab = cell
    cams = cameras(rendered, tmp_path / "cams")
    proc, port = sim_robot(tmp_path, "fault@4")
    try:
        code, data, err = check(root, port, cams, tmp_path / "c.csv", capsys)
    finally:
        proc.terminate()
        proc.communicate(timeout=20)
    assert code == 1 and data is None and "FAULT" in err and len(err.strip().splitlines()) == 1
    logged = read_check_log(tmp_path / "c.csv").checks
    assert len(logged) == 1 and not logged[0].finished and 1 <= len(logged[0].points) < 8


def test_with_no_terminal_and_no_cell_clear_the_robot_never_moves(cell, rendered, tmp_path):
    """Run from cron or a systemd timer without --cell-clear: refused in one line naming the flag,
    before anything is connected."""
    root, lab = cell
    cams = cameras(rendered, tmp_path / "cams")
    with ControllerSim(lab.true_robot, time_scale=0.01) as sim:
        done = robocal(check_argv(root, sim.port, cams, tmp_path / "c.csv"), subprocess.DEVNULL)
        moves = sim.moves
    assert done.returncode == 2 and moves == 0
    assert done.stderr.strip() == ("robocal check: error: no terminal to confirm the robot's motion: add --cell-clear "
                                   "once the cell is clear and guarded (unattended runs: cron, systemd timers)")
    assert not (tmp_path / "c.csv").exists()


@pytest.mark.parametrize("answer, code, moved", [("n", 1, 0), ("y", 0, 8)])
def test_on_a_terminal_the_first_motion_is_asked_once(cell, rendered, tmp_path, answer, code, moved):
    """Standard input a pseudo-terminal on which the technician answers: only yes moves the robot."""
    root, lab = cell
    cams = cameras(rendered, tmp_path / "cams")
    master, terminal = pty.openpty()
    try:
        os.write(master, f"{answer}\n".encode())
        with ControllerSim(lab.true_robot, time_scale=0.01) as sim:
            done = robocal(check_argv(root, sim.port, cams, tmp_path / "c.csv"), terminal)
            moves = sim.moves
    finally:
        os.close(master)
        os.close(terminal)
    assert done.returncode == code, done.stderr
    assert done.stderr.count(f"The robot on {sim.port} will move to 8 check poses. Is the cell clear and the "
                             "emergency stop within reach? [y/N]") == 1
    assert moves == moved
    if answer == "n":
        assert done.stderr.endswith("robocal check: motion not confirmed: the robot was not moved. Clear the cell and "
                                    "answer y, or give --cell-clear.\n")
        assert not (tmp_path / "c.csv").exists()
    else:
        assert len(read_check_log(tmp_path / "c.csv").checks[0].points) == 8


def test_a_tool_change_is_reidentified_by_driving_the_proposed_poses(cell, tmp_path, capsys, monkeypatch):
    """`--out`: the check (out of limits after a 1.5 mm tool change only the cameras see) names the
    tool, the proposed poses are driven, the tool re-identified and the updated robot checked
    within limits at the check poses; exit 3 (the check itself was out of limits). In each of the
    three runs (the check, the proposed poses, the check of the update) every move but the first
    is started ahead, while the marker is located in the pair of the pose before."""
    import copy
    from app.jobs.cell_measure import CellMeasure
    from app.sim_cameras import SimulatedCellCameras

    ahead = []
    start_next = CellMeasure._start_next

    def counted(measure):
        start_next(measure)
        if measure._ahead is not None:
            ahead.append(measure._next)
    monkeypatch.setattr(CellMeasure, "_start_next", counted)
    root, lab = cell
    changed = copy.copy(lab)
    apply_change(changed, "tool:1.5", seed=0)
    cams = SimulatedCellCameras(changed, tmp_path / "cams")
    with ControllerSim(lab.true_robot, time_scale=0.01, on_rest=cams.on_rest) as sim:
        code, data, err = check(root, sim.port, f"{cams.left},{cams.right}", tmp_path / "c.csv", capsys,
                                ["--out", str(tmp_path / "updated.json")])
        moves = sim.moves
    assert code == 3, err
    assert data["change"] == "tool" and data["after"]["rms_mm"] <= data["after"]["rms_limit_mm"], data
    re = data["reidentification"]
    assert moves - 2 * 8 >= 1                     # the check, the proposed poses, the check of the update
    assert len(ahead) == moves - 3, (moves, ahead)
    assert re["rms_after_mm"] < 0.1 * re["rms_before_mm"], re
    assert (tmp_path / "updated.json").is_file()
    logged = read_check_log(tmp_path / "c.csv").checks
    assert len(logged) == 2 and all(c.finished and len(c.points) == 8 for c in logged)


@pytest.mark.parametrize("profile, words", [
    ("robocal_v9", "no protocol profile 'robocal_v9': give a built-in one (grbl_joint_arm, mecademic_meca500, "
                   "robocal_v1) or the path of a protocol profile file (JSON)"),
    ("BAD", "the profile file cannot be used: "),
])
def test_an_unusable_profile_is_refused_before_anything_connects(cell, rendered, tmp_path, capsys, profile, words):
    """--profile is read when the command line is: an unknown name or a profile file that does not
    read as one ends the command (exit 2) in one line naming --profile; the robot never moves."""
    root, lab = cell
    if profile == "BAD":
        profile = str(tmp_path / "profile.json")
        (tmp_path / "profile.json").write_text('{"format": "robocal.protocol/1", "name": "x"}')
    cams = cameras(rendered, tmp_path / "cams")
    with ControllerSim(lab.true_robot, time_scale=0.01) as sim:
        argv = check_argv(root, sim.port, cams, tmp_path / "c.csv")
        argv[argv.index("--profile") + 1] = profile
        code = main(argv + ["--cell-clear"])
        moves = sim.moves
    err = capsys.readouterr().err
    assert code == 2 and moves == 0 and not (tmp_path / "c.csv").exists()
    assert len(err.strip().splitlines()) == 1 and err.startswith("robocal check: error: argument --profile: " + words), err


def test_no_move_is_made_ahead_after_a_fault(cell, rendered, tmp_path, capsys):
    """The fourth move (one made ahead, while the third pair is located) faults: the check stops
    there (exit 1) and no move follows it, ahead or not."""
    root, lab = cell
    cams = cameras(rendered, tmp_path / "cams")
    with ControllerSim(lab.true_robot, time_scale=0.01, faults="fault@4") as sim:
        code, data, err = check(root, sim.port, cams, tmp_path / "c.csv", capsys)
        moves = sim.moves
    assert code == 1 and "FAULT" in err and moves == 4
    assert len(read_check_log(tmp_path / "c.csv").checks[0].points) == 3


def test_ctrl_c_stops_the_robot_and_makes_no_move_ahead(cell, rendered, tmp_path):
    """Ctrl-C (SIGINT) once the robot rested at the third pose: the command ends (exit 130,
    "interrupted"); at most the move already started ahead follows it, and that one is stopped
    where the robot is, not finished at the next pose."""
    import signal
    import threading
    root, lab = cell
    cams = cameras(rendered, tmp_path / "cams")
    Q = read_poses(root / "poses.csv", lab.nominal_robot).Q
    running, signalled = [], threading.Event()
    at_signal = []

    def on_rest(q):
        if len(running) == 1 and not signalled.is_set() and sim.moves == 3:
            at_signal.append(sim.moves)
            sim.time_scale = 0.5         # the move the command may start ahead takes its time
            signalled.set()
            threading.Timer(0.05, running[0].send_signal, (signal.SIGINT,)).start()

    with ControllerSim(lab.true_robot, time_scale=0.01, on_rest=on_rest) as sim:
        # a test run started in the background (`make test &`, nohup) ignores SIGINT, and a child
        # inherits an ignored signal, so Python would never raise KeyboardInterrupt there: the
        # child gets a handled SIGINT instead, which exec resets to the default, as in a terminal
        ignored = signal.signal(signal.SIGINT, signal.default_int_handler)
        try:
            proc = subprocess.Popen([sys.executable, "-m", "app.cli", *check_argv(root, sim.port, cams,
                                                                                  tmp_path / "c.csv"),
                                     "--cell-clear"], stdin=subprocess.DEVNULL, stdout=subprocess.PIPE,
                                    stderr=subprocess.PIPE, text=True, env=dict(os.environ, PYTHONPATH=str(ROOT)))
        finally:
            signal.signal(signal.SIGINT, ignored)
        running.append(proc)
        _, err = proc.communicate(timeout=600)
        moves, joints = sim.moves, sim.joints()
    assert signalled.is_set() and proc.returncode == 130, err
    assert err.strip().endswith("robocal check: interrupted")
    assert moves - at_signal[0] <= 1
    if moves == 4:                   # the move made ahead was stopped on the way
        assert np.abs(joints - lab.nominal_robot.q_to_file(Q[3:4])[0]).max() > 1e-3
