"""`robocal identify` on synthetic measurements (no Qt): the calibrated file, its options, bad input."""
from __future__ import annotations

import pytest

from app.cli import main
from core.robot.model import robot_path
from core.measurement.file import write_measurements
from core.robot.file import read_robot
from core.virtual_lab.synthetic import perturbed_model, simulate_measurements
from tests.app.commands.cli_output import run_json

ROBOT = str(robot_path("educational_6r"))


@pytest.fixture(scope="module")
def data(tmp_path_factory):
    folder = tmp_path_factory.mktemp("cli")
    nominal = read_robot(ROBOT)
    true = perturbed_model(nominal, 4)
    write_measurements(simulate_measurements(true, 40, rng=5), folder / "m.csv")
    return folder


def test_identify_json_and_calibrated_file(data, tmp_path, capsys):
    out = tmp_path / "cal.json"
    code, result, err = run_json(capsys, ["identify", "--robot", ROBOT, "--measurements", str(data / "m.csv"),
                                          "--out", str(out), "--holdout", "0.25", "--seed", "2"])
    assert code == 0 and err == ""
    assert result["rms_before_mm"] > 1.0 and result["rms_after_mm"] < 0.12
    assert result["holdout_rms_after_mm"] < 0.15 and result["holdout"]["n_test_poses"] == 10
    assert result["iterations"] >= 2 and result["rank"] == result["n_parameters"]
    assert result["condition_number"] > 1
    names = {u["name"]: u["reason"] for u in result["unidentifiable"]}
    assert "J1.theta" in names and "first joint axis" in names["J1.theta"]
    assert result["parameters"]["J2.a"]["std"] > 0 and result["parameters"]["J1.theta"]["std"] is None
    calibrated = read_robot(out)
    assert calibrated.calibration["statistics"]["rms_after_mm"] == pytest.approx(result["rms_after_mm"])


def test_identify_text_output_with_options(data, tmp_path, capsys):
    out = tmp_path / "cal.json"
    code = main(["identify", "--robot", ROBOT, "--measurements", str(data / "m.csv"), "--out", str(out),
                 "--kfold", "4", "--fix", "J3.a,marker.x", "--huber", "3"])
    text, err = capsys.readouterr()
    assert code == 0 and err == ""
    assert "4-fold cross validation" in text and f"Wrote {out}" in text
    cal = read_robot(out).calibration
    assert cal["fixed"] == ["J3.a", "marker.x"] and cal["statistics"]["huber"] == 3.0


def bad_run(capsys, tmp_path, measurements_text=None, extra=(), robot=ROBOT, meas_path=None):
    out = tmp_path / "cal.json"
    out.write_text("previous good file")
    if meas_path is None:
        meas_path = tmp_path / "bad.csv"
        meas_path.write_text(measurements_text)
    code = main(["identify", "--robot", robot, "--measurements", str(meas_path), "--out", str(out), *extra])
    _, err = capsys.readouterr()
    assert out.read_text() == "previous good file"                       # a failed run writes nothing
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".cal.json")]
    assert err.count("\n") == 1 and "Traceback" not in err
    return code, err


HEAD = "# robocal.measurements/1\npose,target,q1,q2,q3,q4,q5,q6,x,y,z\n"


def test_bad_numbers_and_joint_count(tmp_path, capsys):
    code, err = bad_run(capsys, tmp_path, HEAD + "0,marker,1,2,3,4,5,6,10,nan,30\n")
    assert code == 1 and "bad.csv: line 3, column 'y': expected a finite number, got 'nan'" in err
    code, err = bad_run(capsys, tmp_path, HEAD + "0,marker,1,2,3,x4,5,6,10,20,30\n")
    assert code == 1 and "line 3, column 'q4': expected a number, got the text 'x4'" in err
    code, err = bad_run(capsys, tmp_path, "# robocal.measurements/1\npose,target,q1,q2,x,y,z\n0,marker,1,2,3,4,5\n")
    assert code == 1 and "the file has 2 joint columns (q1..q2) but the robot has 6 joints" in err


def test_too_few_poses(tmp_path, capsys):
    rows = "".join(f"{i},marker,{i},{2 * i},{3 * i},4,5,6,{10 + i},{20 - i},{30 + i * i}\n" for i in range(5))
    code, err = bad_run(capsys, tmp_path, HEAD + rows)
    assert code == 1 and "too few measurements" in err and "Measure at least" in err


def test_degenerate_poses_name_the_joints(tmp_path, capsys):
    nominal = read_robot(ROBOT)
    true = perturbed_model(nominal, 4)
    meas = simulate_measurements(true, 30, rng=5)
    Q = meas.Q.copy()
    Q[:, 2] = 0.2
    Q[:, 4] = -0.4
    write_measurements(simulate_measurements(true, 30, Q=Q, rng=5), tmp_path / "deg.csv")
    code, err = bad_run(capsys, tmp_path, meas_path=tmp_path / "deg.csv")
    assert code == 1 and "cannot determine" in err and "J3 0.0 deg" in err and "J5 0.0 deg" in err


def test_usage_errors(tmp_path, capsys, data):
    m = str(data / "m.csv")
    code, err = bad_run(capsys, tmp_path, meas_path=data / "m.csv", extra=["--fix", "J9.zz"])
    assert code == 2 and "unknown parameter 'J9.zz'" in err
    code, err = bad_run(capsys, tmp_path, meas_path=data / "m.csv", extra=["--holdout", "1.5"])
    assert code == 2 and "argument --holdout: 1.5 is outside 0 … 1" in err
    code = main(["identify", "--robot", ROBOT, "--measurements", m, "--out", str(tmp_path / "c.json"),
                 "--holdout", "0.2", "--kfold", "3"])
    assert code == 2 and "not allowed with argument" in capsys.readouterr().err


def test_an_unwritable_out_is_refused_with_one_line(tmp_path, capsys, data):
    (tmp_path / "a_file").write_text("x")
    cases = [
        (["identify", "--robot", ROBOT, "--measurements", str(data / "m.csv"),
          "--out", str(tmp_path / "a_file" / "c.json")], 1, "a_file is a file, not a folder"),
        (["identify", "--robot", ROBOT, "--measurements", str(data / "m.csv"), "--out", str(tmp_path)],
         2, "is a folder; give a file name"),
        (["select-poses", "--robot", ROBOT, "--count", "12", "--out", str(tmp_path)], 2, "is a folder"),
        (["export", "--robot", ROBOT, "--format", "urdf", "--out", str(tmp_path / "a_file" / "r.urdf")],
         1, "is a file, not a folder"),
    ]
    for argv, code, words in cases:
        assert main(argv) == code, argv
        err = capsys.readouterr().err
        assert words in err and len(err.strip().splitlines()) == 1, err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a_file"]      # nothing written


def test_identify_with_a_prior_estimated_from_the_measurements(data, tmp_path, capsys):
    out = tmp_path / "cal.json"
    code, result, err = run_json(capsys, ["identify", "--robot", ROBOT, "--measurements", str(data / "m.csv"),
                                          "--out", str(out), "--prior", "auto"])
    assert code == 0 and err == ""
    prior = result["prior"]
    assert prior["chosen_by"] == "empirical Bayes"
    assert prior["weight_length"] > 0 and prior["weight_angle"] > 0
    saved = read_robot(out).calibration["statistics"]["prior"]
    assert (saved["weight_length"], saved["weight_angle"]) == (prior["weight_length"], prior["weight_angle"])
    assert main(["identify", "--robot", ROBOT, "--measurements", str(data / "m.csv"), "--out", str(out),
                 "--prior", "0.01"]) == 0
    text = capsys.readouterr().out
    assert "Prior toward nominal: weight 0.01 (given)" in text


def test_identify_with_orientation(tmp_path, capsys):
    nominal = read_robot(ROBOT)
    true = perturbed_model(nominal, 3, target_mm=0.0)         # the marker on the last joint's axis
    meas = simulate_measurements(true, 40, sigma_mm=0.02, rng=4, with_sigma=True, orientation_sigma_deg=0.02)
    write_measurements(meas, tmp_path / "m.csv")
    argv = ["identify", "--robot", ROBOT, "--measurements", str(tmp_path / "m.csv"), "--out", str(tmp_path / "c.json")]
    code, plain, _ = run_json(capsys, argv)
    assert code == 0 and "orientation" not in plain and plain["parameters"]["J6.theta"]["std"] is None
    code, result, err = run_json(capsys, argv + ["--orientation", "--fix", "marker.rz"])
    assert code == 0 and err == ""
    assert result["orientation"]["determined_only_with_orientation"] == ["J6.theta"]
    assert result["parameters"]["J6.theta"]["std"] > 0 and result["parameters"]["marker.rx"]["std"] > 0
    assert result["orientation"]["rms_after_deg"] < 0.07
    code = main(argv + ["--orientation"])
    text = capsys.readouterr().out
    assert code == 0 and "Orientation (40 points)" in text and "marker.rz" in text


def test_identify_over_a_wizard_calibration_drops_the_wizards_record_of_its_inputs(data, tmp_path, capsys):
    from core.provenance import changed_inputs, inputs_file, record_inputs

    meas = tmp_path / "measurements.csv"
    meas.write_bytes((data / "m.csv").read_bytes())
    out = tmp_path / "calibrated.json"
    out.write_text("{}")
    record_inputs(out, {"measurements.csv": data / "m.csv"})
    meas.write_text(meas.read_text() + "# measured again\n")       # the wizard would call it out of date
    assert changed_inputs(out, {"measurements.csv": meas}) == ["measurements.csv"]
    code, _, err = run_json(capsys, ["identify", "--robot", ROBOT, "--measurements", str(meas), "--out", str(out)])
    assert code == 0 and err == ""
    assert not inputs_file(out).exists() and changed_inputs(out, {"measurements.csv": meas}) == []
