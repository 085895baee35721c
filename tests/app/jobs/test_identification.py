"""The Identification step's jobs with plain arguments: identify from a file (with and without
the virtual lab's true robot), ideal measurements, progress and cancel."""
from __future__ import annotations

import pytest

from app.jobs.identification import generate_ideal_measurements, run_identification
from core.errors import Cancelled
from core.measurement.file import read_measurements, write_measurements
from core.measurement.synthetic import is_synthetic
from core.robot.file import read_robot
from core.robot.model import robot_path
from core.virtual_lab.synthetic import perturbed_model, simulate_measurements
from tests.app.virtual_inputs import make_lab


@pytest.fixture(scope="module")
def robot():
    return read_robot(robot_path("educational_6r"))


def test_identify_from_a_measurements_file(robot, tmp_path):
    path = write_measurements(simulate_measurements(perturbed_model(robot, 1), 30, sigma_mm=0.05, rng=2),
                              tmp_path / "measurements.csv")
    seen = []
    run = run_identification(robot, path, holdout=0.25, seed=3,
                             progress=lambda f, m: seen.append((f, m)))
    assert run.source == path and run.synthetic is None and run.accuracy is None
    assert run.measurements.n_poses == 30
    assert run.result.after.rms_mm < 0.15 < 1.0 < run.result.before.rms_mm
    assert run.result.validation.method == "holdout" and run.result.validation.fraction == 0.25
    assert seen[0] == (0.0, "reading the measurements") and seen[-1] == (1.0, "done")
    with pytest.raises(Cancelled):
        run_identification(robot, path, cancelled=lambda: True)


def test_ideal_measurements_and_the_accuracy_against_the_true_robot(tmp_path):
    lab = make_lab()
    path = generate_ideal_measurements(tmp_path / "measurements.csv", lab, n_poses=30, seed=4)
    assert path == tmp_path / "measurements.csv" and is_synthetic(path)
    meas = read_measurements(path, lab.nominal_robot)
    assert meas.n_poses == 30 and meas.target_names == [lab.target]
    run = run_identification(lab.nominal_robot, path, lab=lab, truth_poses=40, seed=4)
    assert run.synthetic and run.accuracy is not None and run.accuracy.n_configurations == 40
    assert run.accuracy.calibrated.rms_mm < 0.2 * run.accuracy.nominal.rms_mm
