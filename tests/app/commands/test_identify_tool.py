"""`robocal identify-tool` and `robocal check --tool` on a virtual lab with a tool changer (ideal
measurements): the second tool refused until identified, identified from its proposed poses,
then within limits; the wrong tool mounted found; poses proposed for a real robot."""
from __future__ import annotations

import numpy as np
import pytest

from app.cli import main
from app.lab import ideal_lab_measurements, ideal_measure
from core.measurement.file import Measurements, write_measurements
from core.identification.file import write_calibrated_model
from core.identification.solver import identify
from core.monitoring.log import read_check_log
from core.poses.file import read_poses
from core.robot.file import read_robot, write_robot
from tests.core.tools.two_tools import two_tool_robot
from tests.app.commands.cli_output import run_json


@pytest.fixture(scope="module")
def cell(tmp_path_factory, built_lab):
    folder = tmp_path_factory.mktemp("tools")
    robot = write_robot(two_tool_robot(), folder / "robot.json")
    lab = built_lab(read_robot(robot), 0, 0.5)
    write_calibrated_model(identify(lab.nominal_robot, ideal_lab_measurements(lab, 50, sigma_mm=0.05, seed=4)),
                           folder / "calibrated.json")
    return folder / "calibrated.json", robot


def test_identify_the_second_tool_then_check_with_it(cell, tmp_path, capsys):
    calibrated, robot = cell
    lab = ["--lab-robot", str(robot)]
    log, out = tmp_path / "c.csv", tmp_path / "updated.json"
    code = main(["check", "--robot", str(calibrated), "--log", str(log), "--tool", "long_gripper"] + lab)
    assert code == 1 and "has not been identified" in capsys.readouterr().err
    code, data, err = run_json(capsys, ["identify-tool", "--robot", str(calibrated), "--tool", "long_gripper",
                                        "--out", str(out)] + lab)
    assert code == 0, err
    assert data["n_poses"] == 5 and data["sigma_mm"] < 0.2 and data["held_out_rms_mm"] < 0.2
    assert read_robot(out).calibration["tools"] == ["gripper", "long_gripper"]
    code, data, err = run_json(capsys, ["check", "--robot", str(out), "--log", str(log), "--tool", "long_gripper"]
                               + lab)
    assert code == 0 and data["check"]["within"] and data["tool"] == "long_gripper", err
    code, data, err = run_json(capsys, ["check", "--robot", str(out), "--log", str(log), "--tool", "gripper",
                                        "--change", "mount:long_gripper"] + lab)
    assert code == 3 and data["diagnosis"]["kind"] == "tool", err
    assert "the tool 'gripper'" in data["diagnosis"]["text"]
    assert [c.tool for c in read_check_log(log).checks] == ["long_gripper", "gripper"]


def test_poses_for_a_real_robot_then_identify_from_their_measurements(cell, tmp_path, capsys, built_lab):
    calibrated, robot = cell
    poses = tmp_path / "tool_poses.csv"
    code = main(["identify-tool", "--robot", str(calibrated), "--tool", "long_gripper", "--poses-out", str(poses),
                 "--lab-robot", str(robot)])
    assert code == 0 and len(read_poses(poses).q_file) == 5
    lab = built_lab(read_robot(robot), 0, 0.5)
    lab.target = "long_marker"                                  # the robot measured with the long gripper
    model = read_robot(calibrated)
    Q = model.q_from_file(read_poses(poses).q_file)
    measure = ideal_measure(lab, sigma_mm=0.05, seed=8)
    write_measurements(Measurements(pose=np.arange(5), target=["long_marker"] * 5, q_file=model.q_to_file(Q),
                                    xyz=np.array([measure(q) for q in Q])), tmp_path / "tool.csv")
    capsys.readouterr()
    code, data, err = run_json(capsys, ["identify-tool", "--robot", str(calibrated), "--tool", "long_gripper",
                                        "--measurements", str(tmp_path / "tool.csv"), "--out",
                                        str(tmp_path / "u.json")])
    assert code == 0 and data["n_poses"] == 5 and data["rms_after_mm"] < 0.15, err
    code = main(["identify-tool", "--robot", str(calibrated), "--tool", "long_gripper", "--measurements",
                 str(calibrated)])
    assert code == 2 and "--out" in capsys.readouterr().err


def test_a_tool_the_lab_lacks_is_said(cell, tmp_path, capsys):
    calibrated, _ = cell
    code = main(["identify-tool", "--robot", str(calibrated), "--tool", "long_gripper", "--out",
                 str(tmp_path / "u.json"), "--lab"])
    assert code in (1, 2) and "no target 'long_marker'" in capsys.readouterr().err
    assert not (tmp_path / "u.json").exists()


def test_poses_out_with_out_is_refused(cell, tmp_path, capsys):
    calibrated, _ = cell
    code = main(["identify-tool", "--robot", str(calibrated), "--tool", "long_gripper",
                 "--poses-out", str(tmp_path / "p.csv"), "--out", str(tmp_path / "u.json")])
    err = capsys.readouterr().err
    assert code == 2 and "--poses-out only proposes" in err and err.count("\n") == 1
    assert not (tmp_path / "p.csv").exists() and not (tmp_path / "u.json").exists()


def test_a_tool_identified_from_pairs_captured_at_its_poses(cell, tmp_path, capsys, built_lab):
    """The poses proposed with the stereo calibration, the lab's pairs with the long gripper
    mounted written as PNG files, read back through --joints --images."""
    import cv2
    from tests.app.virtual_inputs import true_stereo_yaml

    calibrated, robot = cell
    lab = built_lab(read_robot(robot), 0, 0.5)
    stereo = true_stereo_yaml(lab, tmp_path / "stereo.yaml")
    cv2.imwrite(str(tmp_path / "training.png"), lab.render_training_image())
    poses = tmp_path / "tool_poses.csv"
    assert main(["identify-tool", "--robot", str(calibrated), "--tool", "long_gripper", "--poses-out", str(poses),
                 "--stereo", str(stereo)]) == 0
    lab.target = "long_marker"
    rng = np.random.default_rng(2)
    for side in ("left", "right"):
        (tmp_path / "pairs" / side).mkdir(parents=True)
    for k, q in enumerate(read_robot(calibrated).q_from_file(read_poses(poses).q_file)):
        left, right = lab.render_marker_pair(q, rng)
        cv2.imwrite(str(tmp_path / "pairs" / "left" / f"{k:02d}.png"), left)
        cv2.imwrite(str(tmp_path / "pairs" / "right" / f"{k:02d}.png"), right)
    capsys.readouterr()
    code, data, err = run_json(capsys, ["identify-tool", "--robot", str(calibrated), "--tool", "long_gripper",
                                        "--joints", str(poses), "--images", str(tmp_path / "pairs"), "--stereo",
                                        str(stereo), "--marker", str(tmp_path / "training.png"),
                                        "--out", str(tmp_path / "u.json")])
    assert code == 0, err
    assert data["measured_on"] == f"image files in {tmp_path / 'pairs'}" and data["n_poses"] == 5
    from_pairs = np.array(data["offsets_mm"]["long_marker"])
    code, data, err = run_json(capsys, ["identify-tool", "--robot", str(calibrated), "--tool", "long_gripper",
                                        "--lab-robot", str(robot), "--out", str(tmp_path / "u_lab.json")])
    assert code == 0, err
    np.testing.assert_allclose(from_pairs, data["offsets_mm"]["long_marker"], atol=0.15)   # measured: 0.05 mm apart
    assert read_robot(tmp_path / "u.json").calibration["tools"] == ["gripper", "long_gripper"]


def test_a_tool_identified_on_the_connected_cell(cell, tmp_path, capsys, monkeypatch):
    """`--port --cameras`: the controller simulator on a real pty is driven through the tool's
    proposed poses while the lab's cameras (the long gripper mounted) write what they see to two
    image folders. With no terminal and no --cell-clear nothing moves; with it the offsets agree
    with the virtual lab's."""
    import copy
    import io

    import cv2
    from app.lab import apply_change, build_lab
    from app.sim_cameras import SimulatedCellCameras
    from core.robot.controller_sim import ControllerSim
    from tests.app.virtual_inputs import true_stereo_yaml

    calibrated, robot = cell
    lab = build_lab(read_robot(robot), 0, 0.5)
    stereo = true_stereo_yaml(lab, tmp_path / "stereo.yaml")
    cv2.imwrite(str(tmp_path / "training.png"), lab.render_training_image())
    mounted = copy.copy(lab)
    apply_change(mounted, "mount:long_gripper")
    cameras = SimulatedCellCameras(mounted, tmp_path / "cams")
    monkeypatch.setattr("sys.stdin", io.StringIO())                 # no terminal: nobody to answer
    with ControllerSim(lab.true_robot, time_scale=0.01, on_rest=cameras.on_rest) as sim:
        argv = ["identify-tool", "--robot", str(calibrated), "--tool", "long_gripper", "--port", sim.port,
                "--cameras", f"{cameras.left},{cameras.right}", "--stereo", str(stereo), "--marker",
                str(tmp_path / "training.png"), "--out", str(tmp_path / "u.json")]
        assert main(argv) == 2 and "add --cell-clear once the cell is clear" in capsys.readouterr().err
        assert sim.moves == 0
        code, data, err = run_json(capsys, argv + ["--cell-clear"])
        moves = sim.moves
    assert code == 0, err
    assert data["measured_on"].startswith(f"serial robot on {sim.port}") and data["n_poses"] == 5 and moves == 5
    code, on_lab, err = run_json(capsys, ["identify-tool", "--robot", str(calibrated), "--tool", "long_gripper",
                                          "--lab-robot", str(robot), "--out", str(tmp_path / "u_lab.json")])
    assert code == 0, err
    np.testing.assert_allclose(data["offsets_mm"]["long_marker"], on_lab["offsets_mm"]["long_marker"], atol=0.15)
