"""`robocal compensate` on a calibrated virtual-lab robot: targets in the camera, base and a
fixture frame, a nominal joint program, corrected Cartesian targets for a nominal controller,
G-code and move lists read back by parsers written here, bad input refused. The UR kinematics
file: tests/app/commands/test_export.py."""
from __future__ import annotations

import csv
import re

import numpy as np
import pytest

from app.cli import main
from app.lab import ideal_lab_measurements
from core import transforms as tf
from core.compensation.ik import solve_ik, tcp_poses
from core.fixtures.file import write_fixture_pose
from core.fixtures.frame import FixtureFrame
from core.identification.file import write_calibrated_model
from core.identification.solver import identify
from core.poses.file import read_pose_list, write_poses
from core.robot.file import read_robot, write_robot
from tests.app.commands.cli_output import run_json


@pytest.fixture(scope="module")
def cell(tmp_path_factory, built_lab):
    folder = tmp_path_factory.mktemp("compensate")
    lab = built_lab(None, 0, 0.5)
    write_calibrated_model(identify(lab.nominal_robot, ideal_lab_measurements(lab, 50, sigma_mm=0.05, seed=4)),
                           folder / "calibrated.json")
    write_robot(lab.nominal_robot, folder / "nominal.json")
    lo, hi = lab.nominal_robot.sampling_range(margin=25.0)
    Q = lo + (hi - lo) * np.random.default_rng(11).random((40, lab.nominal_robot.dof))
    # away from singular arms (a stretched elbow, aligned axes), where a few tenths of a millimetre
    # of calibrated geometry move the solution tens of degrees or out of reach
    Q = Q[[_conditioning(lab.nominal_robot, q) > 0.05 for q in Q]][:12]
    assert len(Q) == 12
    return folder, lab, read_robot(folder / "calibrated.json"), Q


def _conditioning(model, q):
    """Smallest over largest singular value of the 6 x 6 Jacobian of the marker (rotation rows
    times 300 mm)."""
    F = model.frames_many(q[None])[0]
    p = tcp_poses(model, q[None], "marker")[0, :3, 3]
    J = np.array([np.r_[np.cross(F[i, :3, 2], p - F[i, :3, 3]), 300.0 * F[i, :3, 2]] for i in range(6)]).T
    s = np.linalg.svd(J, compute_uv=False)
    return s[-1] / s[0]


def _write_targets_csv(path, xyz, rpy_deg=None, q=None):
    """A targets file written here from the format's description (docs/file-formats.md)."""
    header = ["name", "x", "y", "z"] + (["roll", "pitch", "yaw"] if rpy_deg is not None else []) + \
             ([f"q{j + 1}" for j in range(q.shape[1])] if q is not None else [])
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(header)
        for i, p in enumerate(xyz):
            row = [f"t{i}"] + [repr(float(v)) for v in p]
            row += [repr(float(v)) for v in rpy_deg[i]] if rpy_deg is not None else []
            row += [repr(float(v)) for v in q[i]] if q is not None else []
            w.writerow(row)
    return path


def _true_marker(lab, Q):
    return lab.true_robot.target_positions(Q, "marker")


def test_camera_frame_targets_land_on_the_true_robot(cell, tmp_path, capsys):
    folder, lab, cal, Q = cell
    goal = _true_marker(lab, Q) + np.array([3.0, -2.0, 1.0])      # points the cameras located, near reachable ones
    targets = _write_targets_csv(tmp_path / "t.csv", goal)
    out = tmp_path / "j.csv"
    code, data, err = run_json(capsys, ["compensate", "--robot", str(folder / "calibrated.json"), "--targets",
                                        str(targets), "--frame", "camera", "--nominal", str(folder / "nominal.json"),
                                        "--out", str(out)])
    assert code == 0, err
    joints = read_pose_list(out, cal)
    assert joints.pose.tolist() == list(range(len(Q)))
    # the calibrated model reaches every target exactly; the true robot within the calibration's error
    assert np.abs(cal.target_positions(joints.Q, "marker") - goal).max() < 1e-5      # 6 decimals of a degree
    true_err = np.linalg.norm(_true_marker(lab, joints.Q) - goal, axis=1)
    nominal_Q = solve_ik(lab.nominal_robot, goal, frame="measurement", hint=joints.Q).Q
    before = np.linalg.norm(_true_marker(lab, nominal_Q) - goal, axis=1)
    assert true_err.max() < 0.1 and np.sqrt(np.mean(before ** 2)) > 30 * np.sqrt(np.mean(true_err ** 2))
    rows = data["points"]
    assert [r["name"] for r in rows] == [f"t{i}" for i in range(len(Q))]
    assert all(0 < r["predicted_sigma_mm"] < r["predicted_limit_mm"] < 0.2 for r in rows)
    assert data["frame"] == "camera" and data["format"] == "joints"
    text = main(["compensate", "--robot", str(folder / "calibrated.json"), "--targets", str(targets), "--frame",
                 "camera", "--out", str(tmp_path / "j2.csv")])
    assert text == 0
    said = capsys.readouterr().out
    assert "12 of 12 points corrected" in said and "predicted error σ" in said and "95 % within" in said


def test_base_and_fixture_frames_give_the_same_joints(cell, tmp_path, capsys):
    folder, lab, cal, Q = cell
    world = tcp_poses(cal, Q, "marker")
    in_base = tf.invert(cal.base) @ world
    rpy = np.rad2deg([tf.matrix_to_rpy(T[:3, :3]) for T in in_base])
    fixture = tf.pose_to_matrix([250.0, -30.0, 10.0], np.deg2rad([0.0, 5.0, 40.0]))
    in_fixture = tf.invert(fixture) @ in_base
    rpy_f = np.rad2deg([tf.matrix_to_rpy(T[:3, :3]) for T in in_fixture])
    frame = FixtureFrame(fixture, np.eye(6) * 1e-4, "rigid fit", ["a", "b", "c"], np.eye(3), np.eye(3),
                         np.zeros((3, 3)), np.tile(np.eye(3) * 1e-4, (3, 1, 1)))
    write_fixture_pose(tmp_path / "fixture_pose.json", frame, name="plate")
    results = []
    for name, poses, angles, frame_arg in (("base", in_base, rpy, "base"),
                                           ("fixture", in_fixture, rpy_f, str(tmp_path / "fixture_pose.json"))):
        targets = _write_targets_csv(tmp_path / f"{name}.csv", poses[:, :3, 3], angles, cal.q_to_file(Q) + 3.0)
        code, data, err = run_json(capsys, ["compensate", "--robot", str(folder / "calibrated.json"), "--targets",
                                            str(targets), "--frame", frame_arg, "--out", str(tmp_path / f"{name}.j")])
        assert code == 0, err
        assert data["orientation"] is True
        results.append(read_pose_list(tmp_path / f"{name}.j", cal).Q)
    assert "fixture 'plate'" in data["frame"]
    # the hints (3° from the configurations that made the targets) pick those configurations
    for got in results:
        assert np.abs(np.rad2deg(got - Q)).max() < 2e-6


def test_nominal_program_corrected_and_for_a_nominal_controller(cell, tmp_path, capsys):
    folder, lab, cal, Q = cell
    nominal = lab.nominal_robot
    program = tmp_path / "program.csv"
    write_poses(program, nominal.q_to_file(Q))
    out = tmp_path / "corrected.csv"
    code, data, err = run_json(capsys, ["compensate", "--robot", str(folder / "calibrated.json"), "--program",
                                        str(program), "--nominal", str(folder / "nominal.json"), "--out", str(out)])
    assert code == 0, err
    Qc = read_pose_list(out, cal).Q
    meant = tf.invert(nominal.base) @ tcp_poses(nominal, read_pose_list(program, nominal).Q, "marker")
    reached = tf.invert(cal.base) @ tcp_poses(cal, Qc, "marker")
    assert np.abs(reached[:, :3, 3] - meant[:, :3, 3]).max() < 1e-5
    assert np.abs(reached[:, :3, :3] - meant[:, :3, :3]).max() < 1e-7
    assert all(len(r["joint_correction"]) == 6 and r["correction_mm"] > 0.5 for r in data["points"])

    cart = tmp_path / "cartesian.csv"
    code, data, err = run_json(capsys, ["compensate", "--robot", str(folder / "calibrated.json"), "--program",
                                        str(program), "--nominal", str(folder / "nominal.json"),
                                        "--for-controller", "cartesian", "--out", str(cart)])
    assert code == 0, err
    with open(cart, newline="") as f:                       # read back with the csv module only
        rows = list(csv.DictReader(f))
    assert list(rows[0])[:7] == ["name", "x", "y", "z", "roll", "pitch", "yaw"]
    xyz = np.array([[float(r[k]) for k in "xyz"] for r in rows])
    R = np.array([tf.rpy_to_matrix(np.deg2rad([float(r[k]) for k in ("roll", "pitch", "yaw")])) for r in rows])
    # a controller with the nominal kinematics, given these targets, lands on the corrected joints
    ctrl = solve_ik(nominal, xyz, R, tcp="marker", frame="base", hint=Q)
    assert ctrl.ok.all() and np.abs(np.rad2deg(ctrl.Q - Qc)).max() < 1e-4


def _parse_gcode(text):
    """G0 lines of a GRBL program → axis values per line (X Y Z A B C), comments dropped."""
    moves, absolute = [], False
    for line in text.splitlines():
        code = re.sub(r"\(.*?\)", "", line.split(";")[0]).strip()
        if not code:
            continue
        words = re.findall(r"([A-Z])\s*(-?\d+(?:\.\d*)?)", code)
        letters = [w for w, _ in words]
        if ("G", "90") in words:
            absolute = True
        if ("G", "0") in words:
            assert absolute
            moves.append([float(v) for w, v in words if w in "XYZABC"])
        elif letters not in (["G"], ["M"]):
            raise AssertionError(f"unexpected line {line!r}")
    return np.array(moves)


def _parse_moves(text):
    """MOVE lines of a RoboCal-protocol move list (docs/robot-protocol.md); # lines skipped."""
    out = []
    for line in text.splitlines():
        if line.startswith("#") or not line.strip():
            continue
        command, *values = line.split(" ")
        assert command == "MOVE"
        out.append([float(v) for v in values])
    return np.array(out)


def test_gcode_and_moves_read_back(cell, tmp_path, capsys):
    folder, lab, cal, Q = cell
    program = tmp_path / "program.csv"
    write_poses(program, lab.nominal_robot.q_to_file(Q))
    common = ["compensate", "--robot", str(folder / "calibrated.json"), "--program", str(program),
              "--nominal", str(folder / "nominal.json")]
    assert main(common + ["--out", str(tmp_path / "j.csv")]) == 0
    assert main(common + ["--format", "gcode", "--out", str(tmp_path / "p.gcode")]) == 0
    assert main(common + ["--format", "moves", "--out", str(tmp_path / "p.txt")]) == 0
    capsys.readouterr()
    q_deg = read_pose_list(tmp_path / "j.csv", cal).q_file
    g = _parse_gcode((tmp_path / "p.gcode").read_text())
    assert g.shape == q_deg.shape and np.abs(g - q_deg).max() <= 0.0005 + 1e-9
    m = _parse_moves((tmp_path / "p.txt").read_text())
    assert m.shape == q_deg.shape and np.abs(m - q_deg).max() <= 0.00005 + 1e-9


def test_bad_input(cell, tmp_path, capsys):
    folder, lab, cal, Q = cell
    robot = str(folder / "calibrated.json")
    bad = tmp_path / "bad.csv"
    bad.write_text("name,x,y\np,1,2\n")
    assert main(["compensate", "--robot", robot, "--targets", str(bad), "--out", str(tmp_path / "o.csv")]) == 1
    err = capsys.readouterr().err
    assert "bad.csv" in err and "no column 'z'" in err and len(err.strip().splitlines()) == 1
    good = _write_targets_csv(tmp_path / "t.csv", _true_marker(lab, Q[:2]))
    assert main(["compensate", "--robot", robot, "--targets", str(good), "--tcp", "gripper",
                 "--out", str(tmp_path / "o.csv")]) == 2
    assert "no tool point 'gripper'" in capsys.readouterr().err
    far = _write_targets_csv(tmp_path / "far.csv", np.array([[0.0, 0.0, 500.0], [0.0, 0.0, 9000.0]]))
    out = tmp_path / "keep.csv"
    out.write_text("a good result\n")
    assert main(["compensate", "--robot", robot, "--targets", str(far), "--frame", "camera", "--out", str(out)]) == 1
    err = capsys.readouterr().err
    assert "point 't1' cannot be reached: out of reach" in err and "nothing was written" in err
    assert out.read_text() == "a good result\n"
    assert main(["compensate", "--robot", robot, "--program", str(good), "--out", str(out)]) == 2
    assert "--program needs --nominal" in capsys.readouterr().err
    assert main(["compensate", "--robot", robot, "--targets", str(good), "--out", str(good)]) == 2
    capsys.readouterr()
    assert main(["compensate", "--robot", robot, "--targets", str(good), "--frame", "world",
                 "--out", str(tmp_path / "o.csv")]) == 2
    assert "--frame 'world'" in capsys.readouterr().err
