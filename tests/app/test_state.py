"""WizardState: project and robot bookkeeping, robot connection, lazily created virtual lab."""
from __future__ import annotations


import numpy as np
import pytest

from app.state import WizardState
from core.errors import RoboCalError
from core.robot.simulated import SimulatedRobot


@pytest.fixture
def state(qtbot):
    s = WizardState()
    yield s
    s.close()


class FakeLab:
    created = []

    def __init__(self, robot, seed, noise):
        self.nominal_robot = robot
        self.true_robot = robot.copy()
        self.true_robot.joints[0].a += 1.5      # a "real" error
        self.seed, self.noise = seed, noise

    @classmethod
    def create(cls, robot=None, seed=0, noise=0.5):
        lab = cls(robot, seed, noise)
        cls.created.append(lab)
        return lab


@pytest.fixture
def fake_lab(monkeypatch):
    monkeypatch.setattr("app.lab_provider.build_lab",
                        lambda robot, seed, noise: FakeLab.create(robot=robot, seed=seed, noise=noise))
    FakeLab.created.clear()
    return FakeLab


def test_robot_gives_a_connected_simulated_robot(state, qtbot):
    assert state.hardware.robot_connection is None and not state.hardware.stop_robot()
    with qtbot.waitSignals([state.robotChanged, state.hardware.connectionChanged]):
        state.choose_preset("ur5")
    conn = state.hardware.robot_connection
    assert isinstance(conn, SimulatedRobot) and conn.connected
    assert state.hardware.stop_robot() and conn.stopped
    state.choose_preset("puma560")                   # a new robot: the old connection is closed
    assert not conn.connected and state.hardware.robot_connection is not conn


def test_lab_is_created_lazily_once_and_drives_the_connection(state, fake_lab, qtbot):
    state.seed, state.noise = 7, 0.0
    state.choose_preset("educational_6r")
    assert fake_lab.created == []                     # nothing built until asked
    with qtbot.waitSignal(state.labChanged):
        lab = state.labs.ready_now()
    assert state.labs.ready_now() is lab and len(fake_lab.created) == 1
    assert (lab.seed, lab.noise) == (7, 0.0) and lab.nominal_robot is state.robot
    # the simulated robot now moves with the lab's true geometry
    q = np.full(6, 0.2)
    state.hardware.robot_connection.move_to(q)
    assert np.allclose(state.hardware.robot_connection.pose(), lab.true_robot.fk(q))
    # a new robot invalidates the lab
    state.choose_preset("ur5")
    assert state.labs.ready_now() is not lab and len(fake_lab.created) == 2


def test_a_lab_built_on_a_worker_is_adopted_once(state, fake_lab, qtbot):
    state.seed, state.noise = 7, 0.0
    state.choose_preset("educational_6r")
    other_seed = FakeLab.create(robot=state.robot, seed=8, noise=0.0)
    state.labs.adopt_matching(other_seed)                       # built for another seed: not this lab
    assert not state.labs.built
    built = FakeLab.create(robot=state.robot, seed=7, noise=0.0)
    with qtbot.waitSignal(state.labChanged):
        state.labs.adopt_matching(built)
    assert state.labs.built and state.labs.ready_now() is built and len(fake_lab.created) == 2
    assert state.hardware.robot_connection.model is built.true_robot
    state.labs.adopt_matching(FakeLab.create(robot=state.robot, seed=7, noise=0.0))
    assert state.labs.ready_now() is built                         # the first one stays


def test_a_stop_survives_a_new_robot_connection(state, fake_lab, qtbot):
    state.seed, state.noise = 7, 0.0
    state.choose_preset("educational_6r")
    state.hardware.robot_connection.stop()                 # Esc while a page built the lab on a worker
    state.labs.adopt_matching(FakeLab.create(robot=state.robot, seed=7, noise=0.0))
    assert state.hardware.robot_connection.model is state.labs.ready_now().true_robot
    assert state.hardware.robot_connection.stopped         # the new driver refuses to move until Resume


def test_real_virtual_lab_when_present(state):
    state.choose_preset("educational_6r")
    lab = state.labs.ready_now()
    assert lab.true_robot.dof == 6
    assert state.hardware.robot_connection.model is lab.true_robot


def test_step_results_are_handed_on_with_their_signals(state, tmp_path, qtbot):
    state.new_project(tmp_path / "p")
    marker, selection = object(), object()
    with qtbot.waitSignal(state.markerChanged) as got:
        state.set_marker(marker)
    assert got.args == [marker] and state.marker is marker
    state.set_poses(selection)
    with qtbot.waitSignal(state.measurementsChanged) as got:
        state.set_measurements(str(tmp_path / "m.csv"))
    assert state.measurements == tmp_path / "m.csv" and got.args == [tmp_path / "m.csv"]
    state.set_identification("result", "accuracy")
    assert (state.identification, state.accuracy) == ("result", "accuracy")
    state.open_project(tmp_path / "p")               # a (re)opened project starts clean
    assert (state.stereo, state.marker, state.poses, state.measurements, state.identification,
            state.accuracy) == (None,) * 6


def test_request_lab_builds_once_on_a_worker_for_every_page_that_asks(state, fake_lab, qtbot):
    state.seed, state.noise = 7, 0.0
    state.choose_preset("educational_6r")
    got = []
    state.labs.when_ready(lambda lab: got.append(("stereo", lab)))
    state.labs.when_ready(lambda lab: got.append(("marker", lab)))
    assert got == [] and not state.labs.built              # built on the worker, not here
    qtbot.waitUntil(lambda: len(got) == 2, timeout=5000)
    assert len(fake_lab.created) == 1 and got[0][1] is got[1][1] is state.labs.ready_now()
    state.labs.when_ready(lambda lab: got.append(("poses", lab)))
    assert got[-1] == ("poses", state.labs.ready_now())              # there already: at once
    assert state.hardware.robot_connection.model is state.labs.ready_now().true_robot


def test_a_lab_built_for_the_previous_robot_is_dropped(state, fake_lab, qtbot):
    state.choose_preset("educational_6r")
    got, errors = [], []
    state.labs.when_ready(got.append, errors.append)
    state.choose_preset("ur5")                          # while the build runs
    assert errors == ["the robot changed while the virtual lab was being built"]
    qtbot.waitUntil(lambda: not state.labs._runner.busy, timeout=5000)
    qtbot.wait(20)
    assert got == [] and not state.labs.built


def test_save_without_project_is_refused(state):
    with pytest.raises(RoboCalError, match="no project"):
        state.save_project()


def test_temporary_projects_are_removed_on_close(qtbot):
    s = WizardState()
    project = s.temporary_project()
    assert s.is_temporary() and project.file.is_file()
    s.close()
    assert not project.folder.exists()
    s.close()                                         # twice is fine
