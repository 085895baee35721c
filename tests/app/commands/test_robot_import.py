"""`robocal robot-import`: a URDF chain to robot.json with the same forward kinematics."""
from __future__ import annotations

import numpy as np

from app.cli import main
from core.robot.file import read_robot
from core.robot.urdf_import import urdf_forward_kinematics
from tests.core.robot.test_urdf_import import UR5


def test_robot_import_command_writes_a_model_that_loads(tmp_path, capsys):
    path = tmp_path / "ur5.urdf"
    path.write_text(UR5)
    out = tmp_path / "ur5.json"
    assert main(["robot-import", str(path), "--tip", "ee_link", "--out", str(out), "--target", "marker", "0", "0", "50"]) == 0
    assert "6 joints from 'base_link' to 'ee_link'" in capsys.readouterr().out
    model = read_robot(out)
    q = np.array([0.3, -1.2, 0.8, 0.1, -0.5, 2.0])
    assert np.abs(model.fk(q)[:3, 3] - urdf_forward_kinematics(path, q, tip="ee_link")[:3, 3]).max() < 1e-6
    assert model.targets["marker"].tolist() == [0.0, 0.0, 50.0]
    assert main(["robot-import", str(path), "--out", str(path)]) == 2
    assert "the output would overwrite the input" in capsys.readouterr().err
