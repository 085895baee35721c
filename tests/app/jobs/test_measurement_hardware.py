"""The measurement run over hardware: a SerialRobot on the controller simulator's pty, and as
cameras image folders (pairs rendered beforehand by the virtual lab at the planned poses) or
the lab's renderer at the joints the controller reports. Cancel and resume measure every pose
once; a disconnect stops the run and keeps what was measured; a Stop ends the run before the
next pose; teach mode reads the joints, warns off the plan, refuses joints outside the limits."""
from __future__ import annotations

import os
import subprocess
import sys
import threading
from pathlib import Path

import cv2
import numpy as np
import pytest

from app.hardware import CameraChoice, LiveCameras
from app.jobs.measurement_hardware import capture_source, measure_hardware, record_taught_pose
from core.errors import RoboCalError
from core.measurement.file import read_measurements
from core.measurement.run import poses_from_internal, read_rejects, rejects_path_for
from core.robot.controller_sim import ControllerSim
from core.robot.serial_robot import SerialRobot
from core.stereo.rectification import load_rectification
from tests.app.virtual_inputs import lab_marker, make_lab, true_stereo_yaml

N = 6


@pytest.fixture(scope="module")
def lab():
    return make_lab()


@pytest.fixture(scope="module")
def trained(lab):
    return lab_marker(lab)


@pytest.fixture(scope="module")
def rect(lab, tmp_path_factory):
    return load_rectification(true_stereo_yaml(lab, tmp_path_factory.mktemp("stereo") / "stereo.yaml"))


@pytest.fixture(scope="module")
def Q(lab):
    return lab.random_visible_poses(N, np.random.default_rng(11))


@pytest.fixture
def sim(lab):
    with ControllerSim(lab.true_robot, time_scale=0.01) as s:
        yield s


@pytest.fixture
def driver(lab, sim):
    d = SerialRobot(lab.nominal_robot, sim.port, reply_timeout=5.0, move_timeout=20.0)
    d.connect()
    yield d
    d.disconnect()


def rendered_folders(lab, Q, folder):
    """Image folders holding the pair each camera sees at each pose (the recorded 'cameras')."""
    rng = np.random.default_rng(7)
    for side in ("left", "right"):
        (folder / side).mkdir(parents=True)
    for i, q in enumerate(Q):
        left, right = lab.render_marker_pair(q, rng)
        cv2.imwrite(str(folder / "left" / f"{i:03d}.png"), left)
        cv2.imwrite(str(folder / "right" / f"{i:03d}.png"), right)
    return LiveCameras.open(CameraChoice("sources", str(folder / "left"), str(folder / "right")))


def test_a_run_over_a_pty_and_image_folders_cancels_and_resumes(lab, trained, rect, Q, sim, driver, tmp_path):
    poses = poses_from_internal(Q, lab.nominal_robot, ids=np.arange(10, 10 + N))
    out = tmp_path / "measurements.csv"
    cams = rendered_folders(lab, Q, tmp_path / "cams")
    reports = []
    stop_after = 2

    def cancelled():
        return len(reports) >= stop_after

    first = measure_hardware(poses, out, trained, rect, driver, cams,
                             report=lambda o, thumb: reports.append((o, thumb)), cancelled=cancelled)
    assert first.cancelled and len(first.measured) == 2 and first.fault is None
    assert all(t is not None and t.ndim == 3 for _, t in reports)
    assert [line.startswith("MOVE") for line in sim.received].count(True) == 2
    stop_after = 10 ** 6
    second = measure_hardware(poses, out, trained, rect, driver, cams, report=lambda o, t: reports.append(o))
    assert not second.cancelled and second.fault is None
    assert len(second.skipped) == 2 and len(second.measured) == N - 2
    meas = read_measurements(out)
    assert sorted(int(p) for p in meas.pose) == list(range(10, 10 + N))       # each pose once
    np.testing.assert_allclose(meas.q_file, lab.nominal_robot.q_to_file(Q), atol=1e-3)
    truth = np.array([lab.marker_position(q) for q in Q])
    assert np.max(np.linalg.norm(meas.xyz - truth, axis=1)) < 5.0           # mm, left camera frame
    cams.close()


def test_the_lab_renderer_at_the_reported_joints_is_a_capture_source(lab, trained, rect, Q, driver, tmp_path):
    with pytest.raises(RoboCalError, match="no cameras"):
        capture_source(None)
    source = capture_source(None, lab=lab, driver=driver, seed=3)
    result = measure_hardware(poses_from_internal(Q[:3], lab.nominal_robot), tmp_path / "m.csv", trained, rect,
                              driver, source)
    assert len(result.measured) == 3
    assert capture_source("cams", lab=lab, driver=driver) == "cams"            # chosen cameras come first


def test_a_disconnect_stops_the_run_and_keeps_what_was_measured(lab, trained, rect, Q, tmp_path):
    with ControllerSim(lab.true_robot, time_scale=0.01, faults="disconnect@2") as sim:
        driver = SerialRobot(lab.nominal_robot, sim.port, reply_timeout=5.0, move_timeout=20.0)
        driver.connect()
        source = capture_source(None, lab=lab, driver=driver)
        result = measure_hardware(poses_from_internal(Q, lab.nominal_robot), tmp_path / "m.csv", trained, rect,
                                  driver, source)
        driver.disconnect()
    assert "connection is lost" in result.fault and len(result.measured) == 2
    assert len(read_measurements(tmp_path / "m.csv").pose) == 2
    assert driver.stopped


def test_a_stop_ends_the_run_before_the_next_pose(lab, trained, rect, Q, sim, driver, tmp_path):
    source = capture_source(None, lab=lab, driver=driver)
    seen = []

    def report(outcome, thumb):
        seen.append(outcome)
        if len(seen) == 2:
            threading.Thread(target=driver.stop).start()          # the Stop key, from another thread
            threading.Event().wait(0.3)

    result = measure_hardware(poses_from_internal(Q, lab.nominal_robot), tmp_path / "m.csv", trained, rect,
                              driver, source, report=report)
    assert result.cancelled and len(result.measured) == 2
    assert sum(line.startswith("MOVE") for line in sim.received) == 2
    assert len(read_measurements(tmp_path / "m.csv").pose) == 2


def test_teach_mode_reads_the_joints_and_warns_off_the_plan(lab, trained, rect, Q, sim, driver, tmp_path):
    model = lab.nominal_robot
    out = tmp_path / "taught.csv"
    cams = rendered_folders(lab, Q[:2], tmp_path / "cams")
    driver.move_to(Q[0])                                          # the technician's pendant
    planned = model.q_to_file(Q[0]) + np.array([0, 2.5, 0, 0, 0, 0])
    taught = record_taught_pose(5, planned, out, trained, rect, cams, model, driver=driver)
    assert taught.outcome.status == "measured" and taught.thumbnail is not None
    assert taught.warnings == ["J2 is 2.50° from the planned pose"]
    np.testing.assert_allclose(read_measurements(out).q_file[0], model.q_to_file(Q[0]), atol=1e-3)
    with pytest.raises(RoboCalError, match="pose 5 is already measured"):
        record_taught_pose(5, planned, out, trained, rect, cams, model, driver=driver)
    # typed joint values (a robot whose joints cannot be read)
    typed = model.q_to_file(Q[1])
    taught = record_taught_pose(6, typed, out, trained, rect, cams, model, q_typed_file=typed)
    assert taught.outcome.status == "measured" and taught.warnings == []
    bad = typed.copy()
    bad[2] = 500.0
    with pytest.raises(RoboCalError, match=r"joint J3: 500.000° is outside its limits") as exc:
        record_taught_pose(7, typed, out, trained, rect, cams, model, q_typed_file=bad)
    assert "not moved" not in exc.value.message
    assert sorted(read_measurements(out).pose.tolist()) == [5, 6]
    assert read_rejects(rejects_path_for(out)) == {}
    cams.close()


def test_typed_joint_values_are_read_and_checked(lab):
    from app.jobs.measurement_hardware import off_plan, typed_joints

    model = lab.nominal_robot
    np.testing.assert_allclose(typed_joints("10, -20 30\t0 5 6", model), [10, -20, 30, 0, 5, 6])
    np.testing.assert_allclose(typed_joints("10,5; -20; 30; 0; 5; 6", model), [10.5, -20, 30, 0, 5, 6])
    for text, says in (("", "no joint values typed"), ("1 2 3", "3 joint values typed, the robot has 6"),
                       ("1 2 x 4 5 6", "'x' is not a number"), ("1 2 500 4 5 6", "J3: 500.000° is outside")):
        with pytest.raises(RoboCalError, match=says):
            typed_joints(text, model)
    assert off_plan(model, [10, 20, 30, 0, 5, 6], [10, 20, 31.5, 0, 5, 6]) == ["J3 is 1.50° from the planned pose"]


def test_a_move_the_watchdog_stops_is_a_fault_not_a_cancel(lab, trained, rect, Q, tmp_path):
    """`robocal sim-robot --faults drop@3` (a real subprocess on a pty) never says the third move
    is done: the driver's watchdog stops the robot, and the run reports that as a fault with its
    reason, keeping the two poses measured."""
    root = Path(__file__).resolve().parents[3]
    proc = subprocess.Popen([sys.executable, "-m", "app.cli", "sim-robot", "--faults", "drop@3", "--time-scale",
                             "0.01", "--duration", "60"], cwd=tmp_path, env=dict(os.environ, PYTHONPATH=str(root)),
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        port = proc.stdout.readline().strip()
        assert port.startswith("/dev/pts/"), proc.stderr.read() if not port else port
        driver = SerialRobot(lab.nominal_robot, port, reply_timeout=5.0, move_timeout=1.0)
        driver.connect()
        result = measure_hardware(poses_from_internal(Q, lab.nominal_robot), tmp_path / "m.csv", trained, rect,
                                  driver, capture_source(None, lab=lab, driver=driver))
        driver.disconnect()
    finally:
        proc.terminate()
        proc.wait(timeout=20)
    assert not result.cancelled
    assert result.fault is not None and "no done within 1 s; the robot was stopped" in result.fault
    assert len(result.measured) == 2 and len(read_measurements(tmp_path / "m.csv").pose) == 2
    assert driver.stopped
