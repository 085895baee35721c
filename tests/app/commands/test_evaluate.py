"""`robocal evaluate`: a calibrated model's position errors on the measurements it was identified
from, against the nominal model's; a target the robot lacks and a missing file refused (no Qt)."""
from __future__ import annotations

import pytest

from app.cli import main
from core.measurement.file import write_measurements
from core.robot.file import read_robot
from core.robot.model import robot_path
from core.virtual_lab.synthetic import perturbed_model, simulate_measurements
from tests.app.commands.cli_output import run_json

ROBOT = str(robot_path("educational_6r"))


@pytest.fixture(scope="module")
def calibrated(tmp_path_factory):
    """(measurements of a perturbed arm at 40 poses, the model identified from them)."""
    folder = tmp_path_factory.mktemp("evaluate")
    true = perturbed_model(read_robot(ROBOT), 4)
    write_measurements(simulate_measurements(true, 40, rng=5), folder / "m.csv")
    assert main(["identify", "--robot", ROBOT, "--measurements", str(folder / "m.csv"),
                 "--out", str(folder / "cal.json"), "--holdout", "0.25", "--seed", "2"]) == 0
    return folder / "m.csv", folder / "cal.json"


def test_the_calibrated_model_evaluates_well_and_the_nominal_one_does_not(calibrated, capsys):
    measurements, robot = calibrated
    capsys.readouterr()
    code, ev, _ = run_json(capsys, ["evaluate", "--robot", str(robot), "--measurements", str(measurements)])
    assert code == 0 and ev["n"] == 40 and ev["rms_mm"] < 0.15 and len(ev["per_pose"]) == 40
    assert set(ev) >= {"n", "mean_mm", "rms_mm", "max_mm", "per_pose"}
    code, ev0, _ = run_json(capsys, ["evaluate", "--robot", ROBOT, "--measurements", str(measurements),
                                     "--register-base"])
    assert code == 0 and ev0["rms_mm"] > 10 * ev["rms_mm"]


def test_a_target_the_robot_lacks_and_a_missing_file_are_refused(tmp_path, capsys):
    (tmp_path / "probe.csv").write_text("# robocal.measurements/1\npose,target,q1,q2,q3,q4,q5,q6,x,y,z\n"
                                        "0,probe,1,2,3,4,5,6,10,20,30\n")
    code = main(["evaluate", "--robot", ROBOT, "--measurements", str(tmp_path / "probe.csv")])
    err = capsys.readouterr().err          # a model can only be evaluated at targets it defines
    assert code == 1 and "target 'probe' is not defined in the robot" in err
    code = main(["evaluate", "--robot", ROBOT, "--measurements", str(tmp_path / "missing.csv")])
    assert code == 1 and "file not found" in capsys.readouterr().err
