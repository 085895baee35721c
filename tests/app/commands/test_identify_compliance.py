"""`robocal identify --compliance/--payload`, `evaluate --place/--relative-to` and
`import-measurements --placed-robot` on a simulated arm that bends under its weight (no Qt)."""
from __future__ import annotations

import json

import numpy as np
import pytest

from app.cli import main
from core.measurement.file import write_measurements
from core.robot.file import read_robot, write_robot
from core.robot.model import PRISMATIC, Joint, RobotModel, robot_path
from core.virtual_lab.robot_deflection import deflecting_robot
from core.virtual_lab.synthetic import perturbed_model, simulate_measurements
from tests.app.commands.cli_output import run_json

ROBOT = str(robot_path("abb_irb120"))


@pytest.fixture(scope="module")
def data(tmp_path_factory):
    """A deflecting true IRB 120: 40 calibration poses, 20 test poses of a probe tip, and one pose
    where the new probe and the calibrated marker were both measured."""
    folder = tmp_path_factory.mktemp("compliance")
    true = deflecting_robot(perturbed_model(read_robot(ROBOT), 6, length_mm=0.5, angle_deg=0.1), 6,
                            range_deg=(0.05, 0.08))
    true.targets["probe"] = np.array([25.0, -10.0, 60.0])
    write_measurements(simulate_measurements(true, 40, targets=["marker"], sigma_mm=0.02, rng=7), folder / "cal.csv")
    write_measurements(simulate_measurements(true, 20, targets=["probe"], sigma_mm=0.02, rng=8), folder / "test.csv")
    once = simulate_measurements(true, 1, targets=["probe", "marker"], sigma_mm=0.02, rng=9)
    write_measurements(once, folder / "once.csv")
    return folder


def test_auto_keeps_the_deflection_terms_and_records_the_payload(data, tmp_path, capsys):
    out = tmp_path / "cal.json"
    code = main(["identify", "--robot", ROBOT, "--measurements", str(data / "cal.csv"), "--out", str(out),
                 "--compliance", "auto", "--payload", "2.5"])
    text, err = capsys.readouterr()
    assert code == 0 and err == ""
    assert "Deflection under the arm's weight: The arm bends under its weight" in text and "kept." in text
    assert "Payload during calibration: 2.5 kg." in text and "J3.cos_q23" in text
    calibrated = read_robot(out)
    assert calibrated.compliance is not None and not calibrated.compliance.is_zero
    assert calibrated.calibration["payload_kg"] == 2.5
    assert calibrated.calibration["statistics"]["compliance"]["kept"] is True
    code, off, _ = run_json(capsys, ["identify", "--robot", ROBOT, "--measurements", str(data / "cal.csv"),
                                     "--out", str(tmp_path / "off.json")])
    assert code == 0 and off["compliance"] == {"mode": "off", "kept": False,
                                               "verdict": "Geometry only: deflection terms not asked for."}
    assert off["payload_kg"] is None and "compliance" not in json.loads((tmp_path / "off.json").read_text())
    # the deflection terms predict the marker on the calibration poses better than geometry alone
    code, with_terms, _ = run_json(capsys, ["evaluate", "--robot", str(out), "--measurements", str(data / "cal.csv")])
    code, rigid, _ = run_json(capsys, ["evaluate", "--robot", str(tmp_path / "off.json"), "--measurements",
                                       str(data / "cal.csv")])
    assert with_terms["mean_mm"] < 0.7 * rigid["mean_mm"]


def test_a_new_target_placed_relative_to_the_calibrated_marker(data, tmp_path, capsys):
    cal = tmp_path / "geometry.json"
    assert main(["identify", "--robot", ROBOT, "--measurements", str(data / "cal.csv"), "--out", str(cal)]) == 0
    capsys.readouterr()
    base = ["evaluate", "--robot", str(cal), "--measurements", str(data / "test.csv"), "--place", str(data / "once.csv")]
    code, absolute, err = run_json(capsys, base)
    assert code == 0 and absolute["placed"][0]["references"] == []
    code, relative, err = run_json(capsys, base + ["--relative-to", "marker"])
    assert code == 0 and err == "" and relative["n"] == 20
    assert relative["placed"][0]["target"] == "probe" and relative["placed"][0]["references"] == ["marker"]
    # the model's own error at the placing pose cancels in the difference of the two measurements
    assert relative["mean_mm"] < absolute["mean_mm"]
    # import-measurements writes the robot with the probe placed the same way
    placed = tmp_path / "placed.json"
    code, imported, err = run_json(capsys, ["import-measurements", str(data / "once.csv"), "--out",
                                            str(tmp_path / "m.csv"), "--robot", str(cal), "--placed-robot",
                                            str(placed), "--relative-to", "marker"])
    assert code == 0 and imported["placed"][0]["target"] == "probe"
    code, again, _ = run_json(capsys, ["evaluate", "--robot", str(placed), "--measurements", str(data / "test.csv")])
    assert again["mean_mm"] == pytest.approx(relative["mean_mm"], rel=1e-9)


def test_usage_and_data_errors(data, tmp_path, capsys):
    cal = tmp_path / "geometry.json"
    main(["identify", "--robot", ROBOT, "--measurements", str(data / "cal.csv"), "--out", str(cal)])
    capsys.readouterr()
    assert main(["evaluate", "--robot", str(cal), "--measurements", str(data / "test.csv"),
                 "--relative-to", "marker"]) == 2
    assert "--relative-to needs --place" in capsys.readouterr().err
    assert main(["evaluate", "--robot", str(cal), "--measurements", str(data / "test.csv"), "--place",
                 str(data / "once.csv"), "--relative-to", "tip"]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "the reference target 'tip' is not in the robot" in err[0]
    assert main(["import-measurements", str(data / "once.csv"), "--out", str(tmp_path / "m.csv"),
                 "--placed-robot", str(tmp_path / "p.json")]) == 2
    assert "--placed-robot needs --robot" in capsys.readouterr().err
    assert main(["identify", "--robot", ROBOT, "--measurements", str(data / "cal.csv"), "--out",
                 str(tmp_path / "x.json"), "--payload", "heavy"]) == 2
    capsys.readouterr()


def test_compliance_on_a_robot_without_a_vertical_arm_is_refused(tmp_path, capsys):
    scara = RobotModel("SCARA", [Joint(d=300.0, a=250.0, min=-2.5, max=2.5),
                                 Joint(a=200.0, alpha=np.pi, min=-2.5, max=2.5),
                                 Joint(type=PRISMATIC, min=0.0, max=150.0),
                                 Joint(min=-3.0, max=3.0)], targets={"marker": np.array([0.0, 0.0, 30.0])})
    robot = write_robot(scara, tmp_path / "scara.json")
    write_measurements(simulate_measurements(scara, 15, rng=1), tmp_path / "m.csv")
    out = tmp_path / "cal.json"
    assert main(["identify", "--robot", str(robot), "--measurements", str(tmp_path / "m.csv"), "--out", str(out),
                 "--compliance", "auto"]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "joint J3 of 'SCARA' is prismatic" in err[0] and "--compliance off" in err[0]
    assert not out.exists()
