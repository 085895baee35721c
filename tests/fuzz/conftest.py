"""The valid files the fuzzing tests mutate: a measurements file of the educational 6R arm
(20 simulated points), the robot file and a pose file."""
from __future__ import annotations

import shutil

import pytest

from core.measurement.file import write_measurements
from core.robot.file import read_robot
from core.robot.model import robot_path
from core.virtual_lab.synthetic import perturbed_model, simulate_measurements

ROBOT = robot_path("educational_6r")


@pytest.fixture(scope="session")
def files(tmp_path_factory):
    folder = tmp_path_factory.mktemp("fuzz")
    true = perturbed_model(read_robot(ROBOT), 4)
    write_measurements(simulate_measurements(true, 20, rng=5), folder / "m.csv")
    shutil.copy(ROBOT, folder / "robot.json")
    (folder / "poses.csv").write_text("pose,q1,q2,q3,q4,q5,q6\n0,0,10,20,0,30,0\n1,5,-10,15,10,20,5\n")
    return folder
