"""Robot model file: round trip and one clear message per kind of bad input."""
import json
import os
from pathlib import Path

import numpy as np
import pytest

from core.errors import RoboCalError
from core.robot.model import preset_names, robot_path
from core.robot.file import read_robot, robot_file, robot_from_dict, robot_to_dict, write_robot


def _preset_dict(name="educational_6r") -> dict:
    return json.loads(robot_path(name).read_text())


@pytest.mark.parametrize("name", preset_names())
def test_round_trip_preserves_kinematics(tmp_path, name):
    model = read_robot(robot_path(name))
    model.base[:3, 3] = [5.0, -700.0, 810.0]
    model.joints[1].beta = np.deg2rad(0.3)
    path = write_robot(model, tmp_path / "robot.json")
    again = read_robot(path)
    lo, hi = model.limits()
    Q = np.random.default_rng(0).uniform(lo, hi, (10, model.dof))
    np.testing.assert_allclose(again.fk_many(Q), model.fk_many(Q), atol=1e-9)
    assert again.targets.keys() == model.targets.keys()
    np.testing.assert_allclose(again.limits(), model.limits())


def test_calibration_section_is_kept(tmp_path):
    data = _preset_dict()
    data["calibration"] = {"rms_after_mm": 0.05}
    model = robot_from_dict(data)
    write_robot(model, tmp_path / "c.json")
    assert json.loads((tmp_path / "c.json").read_text())["calibration"] == {"rms_after_mm": 0.05}


def _error_for(tmp_path, data) -> str:
    path = tmp_path / "robot.json"
    path.write_text(data if isinstance(data, str) else json.dumps(data))
    with pytest.raises(RoboCalError) as info:
        read_robot(path)
    message = info.value.message
    assert str(path) in message and "\n" not in message
    return message


def test_malformed_json(tmp_path):
    assert "not valid JSON (line 1" in _error_for(tmp_path, '{"format": "robocal.robot/1",')


def test_unknown_major_version(tmp_path):
    data = _preset_dict()
    data["format"] = "robocal.robot/2"
    message = _error_for(tmp_path, data)
    assert "field 'format'" in message and "unknown format version 2" in message


def test_minor_version_is_accepted(tmp_path):
    data = _preset_dict()
    data["format"] = "robocal.robot/1.3"
    (tmp_path / "r.json").write_text(json.dumps(data))
    assert read_robot(tmp_path / "r.json").dof == 6


def test_missing_field(tmp_path):
    data = _preset_dict()
    del data["joints"][2]["alpha"]
    message = _error_for(tmp_path, data)
    assert "field 'joints[2].alpha': missing" in message


def test_angle_given_as_text(tmp_path):
    data = _preset_dict()
    data["joints"][1]["alpha"] = "90deg"
    message = _error_for(tmp_path, data)
    assert "field 'joints[1].alpha'" in message and "expected a number in degrees" in message
    assert "'90deg'" in message


def test_bad_joint_type_and_limits(tmp_path):
    data = _preset_dict()
    data["joints"][0]["type"] = "spherical"
    assert "joints[0].type" in _error_for(tmp_path, data)
    data = _preset_dict()
    data["joints"][3]["min"] = 10
    data["joints"][3]["max"] = -10
    assert "joints[3].min" in _error_for(tmp_path, data)


def test_missing_file(tmp_path):
    with pytest.raises(RoboCalError, match="file not found"):
        read_robot(tmp_path / "nope.json")


def test_failed_write_leaves_previous_file(tmp_path, monkeypatch):
    model = read_robot(robot_path("ur5"))
    path = write_robot(model, tmp_path / "robot.json")
    before = path.read_bytes()

    def broken_replace(src, dst):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(os, "replace", broken_replace)
    with pytest.raises(RoboCalError, match="cannot write"):
        write_robot(read_robot(robot_path("puma560")), path)
    assert path.read_bytes() == before
    assert [p.name for p in tmp_path.iterdir()] == ["robot.json"]  # no temporary left


def test_round_trip_dict_is_stable():
    data = robot_to_dict(robot_from_dict(_preset_dict("abb_irb120")))
    assert robot_to_dict(robot_from_dict(data)) == data


def test_a_folder_or_a_binary_file_is_refused_clearly(tmp_path):
    with pytest.raises(RoboCalError, match="this is a folder, not a file"):
        read_robot(tmp_path)
    (tmp_path / "robot.json").write_bytes(b"\x89PNG\r\n\x1a\n\xff\xfe")
    with pytest.raises(RoboCalError, match="not a text file. Give a JSON file"):
        read_robot(tmp_path / "robot.json")


def test_joint_names_default_and_round_trip(tmp_path):
    ur5 = read_robot(robot_path("ur5"))
    assert [j.name for j in ur5.joints] == ["shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint",
                                             "wrist_1_joint", "wrist_2_joint", "wrist_3_joint"]
    assert [j.name for j in read_robot(write_robot(ur5, tmp_path / "ur5.json")).joints] == [j.name for j in ur5.joints]
    data = _preset_dict()
    for jd in data["joints"]:
        jd.pop("name", None)
    assert [j.name for j in robot_from_dict(data).joints] == [f"J{i}" for i in range(1, 7)]
    data["joints"][0]["name"] = 7
    with pytest.raises(RoboCalError, match=r"field 'joints\[0\]\.name': expected text"):
        robot_from_dict(data)


def test_a_marker_orientation_on_the_tool_round_trips_and_moves_the_predicted_frame(tmp_path):
    """`target_rotations` (identification with orientation estimates the marker's turn on the
    tool) is written as a rotation vector in degrees and read back to the same frame."""
    from scipy.spatial.transform import Rotation

    from core.kinematics.orientation import predict_rotations

    robot = read_robot(robot_path("educational_6r"))
    R = Rotation.from_rotvec([0.3, -12.0, 40.0], degrees=True).as_matrix()
    robot.target_rotations = {"marker": R}
    data = robot_to_dict(robot)
    assert np.allclose(data["target_rotations"]["marker"], [0.3, -12.0, 40.0])
    back = read_robot(write_robot(robot, tmp_path / "r.json"))
    assert np.allclose(back.target_rotations["marker"], R, atol=1e-12)
    q = np.zeros((1, robot.dof))
    assert np.allclose(predict_rotations(back, q, ["marker"]), predict_rotations(robot, q, ["marker"]), atol=1e-12)
    plain = read_robot(robot_path("educational_6r"))
    assert "target_rotations" not in robot_to_dict(plain)      # files without it stay as they were
    bad = dict(data, target_rotations={"nozzle": [0, 0, 1]})
    with pytest.raises(RoboCalError) as info:
        robot_from_dict(bad, "r.json")
    assert info.value.field == "target_rotations.nozzle" and "not in" in info.value.message


@pytest.mark.parametrize("name", ['m"/><link name="x', "../tip", "*"])
def test_a_target_name_that_cannot_be_a_urdf_link_is_refused(tmp_path, name):
    data = _preset_dict()
    data["targets"][name] = [0, 0, 50]
    message = _error_for(tmp_path, data)
    assert f"field 'targets.{name}'" in message and "becomes a file or link name" in message
def test_a_preset_by_name_from_any_folder(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    for value in ("educational_6r", "ur5.json"):
        model = read_robot(value)
        assert model.name == read_robot(robot_path(value.removesuffix(".json"))).name
    assert robot_file("ur5") == robot_path("ur5")
    # a file of that name in the folder is what the user means
    write_robot(read_robot("ur5"), tmp_path / "educational_6r")
    assert robot_file("educational_6r") == Path("educational_6r") and read_robot("educational_6r").dof == 6
    assert read_robot("educational_6r").name == read_robot(robot_path("ur5")).name


def test_neither_a_file_nor_a_preset_lists_the_presets(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    for value, says in (("educational_7r", "file not found, and not the name of a preset robot"),
                        ("lab/calibrated.json", "file not found"), ("sub/ur5", "file not found")):
        with pytest.raises(RoboCalError, match=says) as err:
            read_robot(value)
        assert value in str(err.value) and "educational_6r, fanuc_lrmate200id" in err.value.hint
    assert "preset" not in str(err.value).split(".")[0]                   # a path is not a preset name
