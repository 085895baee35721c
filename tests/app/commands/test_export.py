"""`robocal export`: a robot file as URDF, a DH table (CSV) and a Universal Robots controller's
kinematics file; a format it does not write, and a robot that is not a UR arm, refused."""
from __future__ import annotations

import pytest
import yaml

from app.cli import main
from core.robot.model import robot_path
from tests.app.commands.cli_output import run_json

ROBOT = str(robot_path("educational_6r"))


def test_export_urdf_and_dh_csv(tmp_path, capsys):
    code, res, _ = run_json(capsys, ["export", "--robot", ROBOT, "--format", "urdf", "--out", str(tmp_path / "r.urdf")])
    assert code == 0 and res["format"] == "urdf" and (tmp_path / "r.urdf").read_text().startswith("<?xml")
    code = main(["export", "--robot", ROBOT, "--format", "dh-csv", "--out", str(tmp_path / "dh.csv")])
    assert code == 0 and (tmp_path / "dh.csv").read_text().startswith("joint,type,theta_deg")
    assert "Wrote" in capsys.readouterr().out
    code = main(["export", "--robot", ROBOT, "--format", "sdf", "--out", str(tmp_path / "x")])
    assert code == 2 and "invalid choice" in capsys.readouterr().err


def test_export_ur_kinematics(tmp_path, capsys):
    code = main(["export", "--robot", str(robot_path("ur5")), "--format", "ur-kinematics",
                 "--out", str(tmp_path / "k.yaml"), "--json"])
    assert code == 0
    kin = yaml.safe_load((tmp_path / "k.yaml").read_text())["kinematics"]
    assert kin["forearm"]["x"] == pytest.approx(-0.425)
    assert main(["export", "--robot", str(robot_path("puma560")), "--format", "ur-kinematics",
                 "--out", str(tmp_path / "p.yaml")]) == 1
    assert "not a Universal Robots arm" in capsys.readouterr().err and not (tmp_path / "p.yaml").exists()
