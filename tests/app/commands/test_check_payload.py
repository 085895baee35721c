"""`robocal check --payload` (the declared payload against the calibration's) and `--place
--relative-to` (a target measured once placed on the tool with its uncertainty, then checked), on the
virtual lab of a robot file whose tool carries the probe too (the lab's truth knows where it sits)."""
from __future__ import annotations

import numpy as np
import pytest

from app.cli import main
from app.lab import build_lab, ideal_lab_measurements
from core.identification.file import write_calibrated_model
from core.identification.solver import identify
from core.measurement.file import write_measurements
from core.robot.file import read_robot, write_robot
from core.virtual_lab.synthetic import simulate_measurements
from tests.app.commands.cli_output import run_json

PROBE = np.array([20.0, -15.0, 40.0])       # mm on the nominal tool


@pytest.fixture(scope="module")
def lab_files(tmp_path_factory):
    """The folder: lab_robot.json (the educational 6R with a probe beside the marker), calibrated
    on the marker alone with a 2.5 kg payload (payload.json) and with none recorded (unknown.json),
    once.csv (the probe and the marker measured in one pose)."""
    folder = tmp_path_factory.mktemp("checkpayload")
    robot = build_lab(None, 0, 0.5).nominal_robot.copy()
    robot.targets["probe"] = PROBE
    write_robot(robot, folder / "lab_robot.json")
    lab = build_lab(read_robot(folder / "lab_robot.json"), 0, 0.5)
    meas = ideal_lab_measurements(lab, 50, sigma_mm=0.05, seed=4)
    nominal = lab.nominal_robot.copy()
    del nominal.targets["probe"]
    write_calibrated_model(identify(nominal, meas, payload_kg=2.5), folder / "payload.json")
    write_calibrated_model(identify(nominal, meas), folder / "unknown.json")
    write_measurements(simulate_measurements(lab.true_robot, 1, targets=["probe", "marker"], sigma_mm=0.05, rng=5),
                       folder / "once.csv")
    return folder


def check(folder, robot, log, *more):
    return ["check", "--robot", str(folder / robot), "--log", str(log), "--lab-robot", str(folder / "lab_robot.json"),
            *more]


def test_a_different_payload_is_said_in_one_line(lab_files, tmp_path, capsys):
    code = main(check(lab_files, "payload.json", tmp_path / "c.csv", "--payload", "4"))
    lines = capsys.readouterr().out.splitlines()
    assert code == 0
    said = [line for line in lines if line.startswith("Payload:")]
    assert said == ["Payload: 4 kg declared, 2.5 kg during calibration: the arm bends more under a heavier tool."]
    code, data, err = run_json(capsys, check(lab_files, "payload.json", tmp_path / "c.csv", "--payload", "4"))
    assert code == 0 and err == ""
    assert data["payload"] == {"declared_kg": 4.0, "calibration_kg": 2.5, "differs": True, "deflection_terms": False}


def test_the_same_payload_says_nothing_and_an_unrecorded_one_says_so(lab_files, tmp_path, capsys):
    code = main(check(lab_files, "payload.json", tmp_path / "c.csv", "--payload", "2.5"))
    assert code == 0 and "Payload" not in capsys.readouterr().out
    code, data, _ = run_json(capsys, check(lab_files, "unknown.json", tmp_path / "c.csv", "--payload", "2.5"))
    assert code == 0 and data["payload"]["calibration_kg"] is None and not data["payload"]["differs"]
    main(check(lab_files, "unknown.json", tmp_path / "c.csv", "--payload", "2.5"))
    assert "the calibration did not record the payload" in capsys.readouterr().out
    code, data, _ = run_json(capsys, check(lab_files, "unknown.json", tmp_path / "c.csv"))
    assert code == 0 and data["payload"] is None


def test_a_target_placed_relative_to_the_marker_is_the_one_checked(lab_files, tmp_path, capsys):
    code, data, err = run_json(capsys, check(lab_files, "payload.json", tmp_path / "c.csv", "--place",
                                             str(lab_files / "once.csv"), "--relative-to", "marker"))
    assert code == 0 and err == "" and data["check"]["within"]
    placed = data["placed"][0]
    assert placed["target"] == "probe" and placed["references"] == ["marker"]
    # the calibrated tool frame is not the true one, but the probe's distance from the marker is kept
    calibrated = read_robot(lab_files / "payload.json")
    true = build_lab(read_robot(lab_files / "lab_robot.json"), 0, 0.5).true_robot
    placed_distance = np.linalg.norm(np.array(placed["offset_mm"]) - calibrated.targets["marker"])
    assert placed_distance == pytest.approx(np.linalg.norm(true.targets["probe"] - true.targets["marker"]), abs=0.2)
    # the check measured the probe, its limits with the placement's uncertainty: the two measurements' noise
    # (σ√2 per axis with the calibration's σ) and more
    assert {p["target"] for p in data["check"]["points"]} == {"probe"} and len(data["check"]["points"]) == 8
    noise = data["check"]["sigma_mm"]
    assert placed["sigma_mm"] > np.sqrt(2.0) * noise
    marker = run_json(capsys, check(lab_files, "payload.json", tmp_path / "m.csv"))[1]
    assert min(p["limit_mm"] for p in data["poses"]) > max(p["limit_mm"] for p in marker["poses"])
    main(check(lab_files, "payload.json", tmp_path / "c.csv", "--place", str(lab_files / "once.csv"),
               "--relative-to", "marker"))
    line = next(x for x in capsys.readouterr().out.splitlines() if x.startswith("probe placed"))
    assert line.startswith("probe placed relative to marker from pose 0: (") and line.endswith(
        f"mm on the tool, σ {placed['sigma_mm']:.3f} mm per axis (the target checked)")


def test_a_placed_target_the_lab_does_not_carry_is_refused(lab_files, tmp_path, capsys):
    assert main(["check", "--robot", str(lab_files / "payload.json"), "--log", str(tmp_path / "c.csv"), "--lab",
                 "--place", str(lab_files / "once.csv"), "--relative-to", "marker"]) == 2
    err = capsys.readouterr().err
    assert "the virtual lab's robot has no target 'probe'" in err and "--lab-robot" in err


def test_relative_to_without_place_and_an_unknown_reference_are_refused(lab_files, tmp_path, capsys):
    assert main(check(lab_files, "payload.json", tmp_path / "c.csv", "--relative-to", "marker")) == 2
    assert "--relative-to needs --place" in capsys.readouterr().err
    assert main(check(lab_files, "payload.json", tmp_path / "c.csv", "--place", str(lab_files / "once.csv"),
                      "--relative-to", "tip")) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "the reference target 'tip' is not in the robot" in err[0]


def test_a_calibration_with_deflection_terms_says_they_hold_for_its_payload(tmp_path, capsys, built_lab):
    from core.virtual_lab.ideal_measurements import ideal_lab_measurements as lab_points

    lab = built_lab(seed=0, noise=0.5, deflection=True)
    write_calibrated_model(identify(lab.nominal_robot, lab_points(lab, 40, sigma_mm=0.02, seed=4), compliance="on",
                                    payload_kg=1.0), tmp_path / "bent.json")
    write_measurements(lab_points(lab, 8, sigma_mm=0.02, seed=9), tmp_path / "check.csv")
    code, data, err = run_json(capsys, ["check", "--robot", str(tmp_path / "bent.json"), "--log",
                                        str(tmp_path / "c.csv"), "--measurements", str(tmp_path / "check.csv"),
                                        "--payload", "3"])
    assert code == 0 and err == "" and data["check"]["within"]
    assert data["payload"] == {"declared_kg": 3.0, "calibration_kg": 1.0, "differs": True, "deflection_terms": True}
    main(["check", "--robot", str(tmp_path / "bent.json"), "--log", str(tmp_path / "c.csv"), "--measurements",
          str(tmp_path / "check.csv"), "--payload", "3"])
    assert ("Payload: 3 kg declared, 1 kg during calibration: its deflection terms hold for 1 kg (a heavier tool "
            "bends the arm more).") in capsys.readouterr().out.splitlines()
