"""The accuracy map: a grid in the calibrated workspace reached with the nominal and the calibrated
model, on the virtual lab (the true marker position, and through rendered images located by the
trained marker) and over the controller simulator on a real pseudo-terminal (a SerialRobot moves
the lab's true robot; the lab's cameras render where the controller reports the joints); the
file written and read back; Cancel keeps what was measured."""
from __future__ import annotations

import numpy as np
import pytest

from core.compensation.accuracy_map import run_accuracy_map
from core.compensation.accuracy_map_file import read_accuracy_map, write_accuracy_map
from core.compensation.workspace_grid import workspace_grid
from core.errors import RoboCalError
from core.identification.solver import identify
from core.marker.location import MarkerLocator
from core.measurement.capture import RenderedSource
from core.robot.controller_sim import ControllerSim
from core.robot.serial_robot import SerialRobot
from core.stereo.rectification import load_rectification
from core.virtual_lab.ideal_measurements import ideal_lab_measurements, ideal_measure
from tests.app.virtual_inputs import lab_marker, true_stereo_yaml


@pytest.fixture(scope="module")
def lab(built_lab):
    return built_lab(seed=0, noise=0.5)


@pytest.fixture(scope="module")
def calibration(lab):
    meas = ideal_lab_measurements(lab, 50, sigma_mm=0.05, seed=4)
    return meas, identify(lab.nominal_robot, meas).model


@pytest.fixture(scope="module")
def locator(lab, tmp_path_factory):
    rect = load_rectification(true_stereo_yaml(lab, tmp_path_factory.mktemp("stereo") / "stereo.yaml"))
    return MarkerLocator(lab_marker(lab), rect)


def visible(lab):
    return lambda Q: lab.visibility(Q).visible


@pytest.fixture(scope="module")
def grids(lab, calibration):
    """The workspace grids of 20 and of 5 points for the calibration, built once for the tests that
    use each (deterministic; read only: the accuracy map copies the points it reaches)."""
    meas, model = calibration
    return {count: workspace_grid(model, meas.Q, count=count, keep=visible(lab)) for count in (20, 5)}


def truth_error(lab, model, Q, target="marker"):
    """|true − model| marker position at Q (mm): the calibrated model's own error."""
    return np.linalg.norm(lab.true_robot.target_positions(Q, target) - model.target_positions(Q, target), axis=1)


def test_grid_lies_in_the_measured_workspace_and_is_reachable(lab, calibration, grids):
    meas, model = calibration
    grid = grids[20]
    assert len(grid.points) == 20 and len(np.unique(grid.points.round(3), axis=0)) == 20
    np.testing.assert_allclose(model.target_positions(grid.hints, "marker"), grid.points, atol=1e-5)
    assert lab.visibility(grid.hints).visible.all() and model.within_limits(grid.hints).all()
    seen = model.target_positions(meas.Q, "marker")
    lo, hi = seen.min(axis=0), seen.max(axis=0)
    assert np.all((grid.points >= lo) & (grid.points <= hi))
    with pytest.raises(RoboCalError, match="too few"):
        workspace_grid(model, meas.Q[:3])


def test_on_the_lab_the_calibrated_model_lands_where_its_own_error_says(lab, calibration, grids, tmp_path):
    _, model = calibration
    grid = grids[20]
    amap = run_accuracy_map(lab.nominal_robot, model, grid, ideal_measure(lab, sigma_mm=0.0),
                            measured_by="virtual lab, true marker position")
    assert amap.both.sum() >= 18 and not amap.cancelled
    # after: the true robot at the corrected joints is off by exactly the model's own error there
    both = amap.both
    np.testing.assert_allclose(amap.errors_after, truth_error(lab, model, amap.q_after[both]), atol=1e-5)
    # before: the nominal joints put the nominal model's marker on the target, the true robot elsewhere
    nominal_marker = lab.nominal_robot.copy()
    nominal_marker.base = model.base
    np.testing.assert_allclose(nominal_marker.target_positions(amap.q_before[both], "marker"),
                               amap.targets[both], atol=1e-4)
    assert amap.rms_before_mm > 2.0 and amap.rms_after_mm < 0.1 and amap.improvement > 30
    path = write_accuracy_map(tmp_path / "accuracy_map.json", amap, model)
    back = read_accuracy_map(path, model)
    assert back.measured_by == amap.measured_by and back.n == amap.n
    np.testing.assert_allclose(back.errors_before, amap.errors_before, atol=1e-9)
    np.testing.assert_allclose(back.q_after[both], amap.q_after[both], atol=1e-9)


def test_through_rendered_images(lab, calibration, locator, grids):
    _, model = calibration
    grid = grids[5]
    rng = np.random.default_rng(2)

    def measure(q):
        loc = locator.locate(*lab.render_marker_pair(q, rng))
        return loc.point if loc.ok else None
    amap = run_accuracy_map(lab.nominal_robot, model, grid, measure, measured_by="virtual lab images")
    assert amap.both.sum() >= 4
    # the images add the cameras' own error (≈ 0.1 mm) to the model's
    assert amap.rms_after_mm < 0.3 and amap.rms_before_mm > 2.0


def test_over_sim_robot_on_a_pty(lab, calibration, locator, grids):
    _, model = calibration
    grid = grids[5]
    rng = np.random.default_rng(3)
    with ControllerSim(lab.true_robot, time_scale=0.01) as sim:
        driver = SerialRobot(lab.nominal_robot, sim.port, reply_timeout=5.0, move_timeout=20.0)
        driver.connect()
        source = RenderedSource(lambda: lab.render_marker_pair(driver.current_joints(), rng))

        def measure(q):
            driver.move_to(q)
            frames = source.capture()
            loc = locator.locate(frames.left, frames.right)
            return loc.point if loc.ok else None
        amap = run_accuracy_map(lab.nominal_robot, model, grid, measure, measured_by="sim-robot over a pty")
        driver.disconnect()
    moves = [line for line in sim.received if line.startswith("MOVE")]
    assert len(moves) == 2 * amap.both.sum() and amap.both.sum() >= 4
    assert amap.rms_after_mm < 0.3 and amap.improvement > 10


def test_cancel_keeps_what_was_measured(lab, calibration):
    meas, model = calibration
    grid = workspace_grid(model, meas.Q, count=6, keep=visible(lab))
    calls = []

    def measure(q):
        calls.append(q)
        return lab.marker_position(q)
    amap = run_accuracy_map(lab.nominal_robot, model, grid, measure, measured_by="lab",
                            cancelled=lambda: len(calls) >= 4)
    assert amap.cancelled and amap.both.sum() == 2 and len(calls) == 4
