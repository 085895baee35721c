"""The Check step's work on a real cell without the page: a newly mounted tool identified by
driving the controller simulator (a real pty) through the tool's proposed poses while the virtual
lab's cameras, watching the simulator's robot, write their pairs to two image folders; then a
check with that tool is within limits. Choosing poses for a cell uses its calibrated depth range."""
from __future__ import annotations

import copy

import numpy as np
import pytest

from app.hardware import CameraChoice, LiveCameras, RobotChoice, open_serial_robot
from app.jobs.cell_check import check_cell, identify_tool_cell, setup_cell
from app.jobs.cell_measure import CellMeasure, cell_options, locator
from app.lab import apply_change, ideal_lab_measurements, write_ideal_measurements
from app.sim_cameras import SimulatedCellCameras
from core.identification.file import write_calibrated_model
from core.identification.solver import identify
from core.robot.controller_sim import ControllerSim
from core.stereo.rectification import load_rectification
from tests.app.virtual_inputs import lab_marker, true_stereo_yaml
from tests.core.tools.two_tools import two_tool_robot


@pytest.fixture(scope="module")
def cell(tmp_path_factory, built_lab):
    """A lab of the two-tool robot, its calibration (gripper only), stereo.yaml and trained marker."""
    folder = tmp_path_factory.mktemp("cell")
    lab = built_lab(two_tool_robot(), 0, 0.5)
    meas = ideal_lab_measurements(lab, 50, sigma_mm=0.05, seed=4)
    write_ideal_measurements(meas, folder / "measurements.csv", sigma_mm=0.05)
    write_calibrated_model(identify(lab.nominal_robot, meas), folder / "calibrated.json")
    rect = load_rectification(true_stereo_yaml(lab, folder / "stereo.yaml"))
    return lab, folder, rect, lab_marker(lab)


def test_cell_options_take_the_calibrated_depth_range(cell):
    lab, folder, rect, _ = cell
    options = cell_options(rect.calibration.rig, folder / "measurements.csv")
    z = np.asarray(ideal_lab_measurements(lab, 50, sigma_mm=0.05, seed=4).xyz)[:, 2]
    span = z.max() - z.min()
    np.testing.assert_allclose(np.ravel(options["rig"].T), np.ravel(lab.rig.T), atol=1e-6)    # the calibrated rig
    np.testing.assert_allclose(options["rig"].R, lab.rig.R, atol=1e-9)
    assert options["visibility"].min_depth == pytest.approx(z.min() - 0.1 * span, abs=0.5)
    assert options["visibility"].max_depth == pytest.approx(z.max() + 0.1 * span, abs=0.5)
    assert "visibility" not in cell_options(rect.calibration.rig, folder / "absent.csv")


def test_a_mounted_tool_is_identified_by_driving_its_poses(cell, tmp_path):
    lab, folder, rect, trained = cell
    calibrated = tmp_path / "calibrated.json"
    calibrated.write_bytes((folder / "calibrated.json").read_bytes())
    mounted = copy.copy(lab)
    apply_change(mounted, "mount:long_gripper")            # the tool changer took the long gripper
    cameras = SimulatedCellCameras(mounted, tmp_path / "cams")
    sim = ControllerSim(lab.true_robot, time_scale=0.01, on_rest=cameras.on_rest).start()
    live = LiveCameras.open(CameraChoice("sources", str(cameras.left), str(cameras.right)))
    driver = open_serial_robot(lab.nominal_robot, RobotChoice("serial", sim.port, "robocal_v1"), reply_timeout=10.0)
    try:
        options = cell_options(rect.calibration.rig, folder / "measurements.csv")
        measure = CellMeasure(driver, live, locator(trained, rect))
        update = identify_tool_cell(calibrated, "long_gripper", measure, options)
        assert measure.fault is None and measure.moves == len(update.proposed) == sim.moves
        assert update.path == calibrated and any((tmp_path / "history").iterdir())
        model = update.identification.reidentification.model
        assert "long_gripper" in model.calibration["tools"]
        check = setup_cell(calibrated, options, count=6, tool="long_gripper")
        result, diagnosis = check_cell(check, CellMeasure(driver, live, locator(trained, rect)))
        assert len(result.points) == 6 and result.within and diagnosis is None, result.verdict()
    finally:
        driver.disconnect()
        live.close()
        sim.close()


def test_teach_mode_reads_the_joints_a_controller_reports(cell, tmp_path):
    """A check pose recorded where the robot was brought (2° off the plan on J1): the joints are read
    from the controller, the difference from the plan is warned about, the marker is located."""
    from app.jobs.cell_teach import record_check_pose

    lab, folder, rect, trained = cell
    cameras = SimulatedCellCameras(lab, tmp_path / "cams")
    sim = ControllerSim(lab.true_robot, time_scale=0.01, on_rest=cameras.on_rest).start()
    live = LiveCameras.open(CameraChoice("sources", str(cameras.left), str(cameras.right)))
    driver = open_serial_robot(lab.nominal_robot, RobotChoice("serial", sim.port, "robocal_v1"), reply_timeout=10.0)
    try:
        check = setup_cell(folder / "calibrated.json", cell_options(rect.calibration.rig, folder / "measurements.csv"),
                           count=5)
        brought = check.Q[0] + np.deg2rad([2.0, 0, 0, 0, 0, 0])
        driver.move_to(brought)                                 # the pendant's work
        taught = record_check_pose(check, 0, live, locator(trained, rect), driver=driver)
    finally:
        driver.disconnect()
        live.close()
        sim.close()
    np.testing.assert_allclose(taught.q, brought, atol=1e-4)
    assert taught.warnings == ["J1 is 2.00° from the planned pose"]
    expected = lab.true_robot.target_position(brought, lab.target)
    assert taught.point is not None and np.linalg.norm(taught.point - expected) < 0.2
