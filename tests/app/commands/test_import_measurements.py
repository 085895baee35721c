"""`robocal import-measurements`: a tracker's CSV to measurements.csv, then identified."""
from __future__ import annotations

import json

import numpy as np

from app.cli import main
from core.measurement.file import read_measurements
from core.robot.file import read_robot
from core.robot.model import robot_path
from core.virtual_lab.synthetic import perturbed_model, simulate_measurements

ROBOT = robot_path("educational_6r")


def test_a_tracker_csv_becomes_measurements_that_identify(tmp_path, capsys):
    true = perturbed_model(read_robot(ROBOT), 3)
    meas = simulate_measurements(true, 30, rng=4)
    lines = ["X_m,Y_m,Z_m,q1_rad,q2_rad,q3_rad,q4_rad,q5_rad,q6_rad,pose"]
    for i in range(meas.n_points):
        lines.append(",".join(f"{v:.9f}" for v in [*meas.xyz[i] / 1000, *np.deg2rad(meas.q_file[i])])
                     + f",{meas.pose[i]}")
    src = tmp_path / "tracker.csv"
    src.write_text("\n".join(lines) + "\n")
    out = tmp_path / "m.csv"
    assert main(["import-measurements", str(src), "--out", str(out), "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert (data["points"], data["poses"], data["targets"]) == (30, 30, ["marker"])
    got = read_measurements(out)
    np.testing.assert_allclose(got.xyz, meas.xyz, atol=1e-5)
    assert main(["identify", "--robot", str(ROBOT), "--measurements", str(out), "--out",
                 str(tmp_path / "cal.json")]) == 0
    capsys.readouterr()
    # the output may not be the input, and a broken row is one line naming the file
    assert main(["import-measurements", str(src), "--out", str(src)]) == 2
    assert "--out is the same file as the CSV file" in capsys.readouterr().err
    src.write_text(lines[0] + "\n1,2,3,x,0,0,0,0,0,0\n")
    assert main(["import-measurements", str(src), "--out", str(tmp_path / "n.csv")]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and str(src) in err[0] and "q1_rad" in err[0]
