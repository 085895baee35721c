"""Project folders: project.json and the step outputs beside it (no Qt here)."""
from __future__ import annotations

import json

import numpy as np
import pytest

from core import project as proj
from core.errors import RoboCalError
from core.robot.model import robot_path
from core.robot.file import read_robot


@pytest.fixture
def model():
    return read_robot(robot_path("educational_6r"))


def test_create_writes_a_versioned_project_file(tmp_path):
    p = proj.create_project(tmp_path / "cell-3", mode="virtual-lab")
    data = json.loads((tmp_path / "cell-3" / "project.json").read_text())
    assert data["format"] == "robocal.project/1"
    assert data["name"] == "cell-3"
    assert data["mode"] == "virtual-lab"
    assert data["robot"] is None
    assert data["created"].endswith("+00:00")
    assert p.folder == tmp_path / "cell-3"


def test_open_round_trip_with_robot(tmp_path, model):
    p = proj.create_project(tmp_path, name="Lab arm")
    proj.save_robot(p, model, source="preset:educational_6r")
    assert (tmp_path / "robot.json").is_file() and p.has(proj.Output.ROBOT)
    for where in (tmp_path, tmp_path / "project.json"):
        q = proj.open_project(where)
        assert (q.name, q.mode, q.robot, q.robot_source) == ("Lab arm", "virtual-lab", "robot.json",
                                                             "preset:educational_6r")
        loaded = proj.load_robot(q)
        assert loaded.dof == 6
        assert np.allclose(loaded.fk(np.full(6, 0.3)), model.fk(np.full(6, 0.3)))


def test_output_paths_sit_beside_the_project_file(tmp_path):
    p = proj.create_project(tmp_path)
    Output = proj.Output
    assert p.path(Output.STEREO) == tmp_path / "stereo.yaml"
    assert p.path(Output.STEREO_DETAILS) == tmp_path / "stereo.json"
    assert p.path(Output.MEASUREMENTS) == tmp_path / "measurements.csv"
    assert p.path(Output.POSES) == tmp_path / "poses.csv"
    assert p.path(Output.CALIBRATED) == tmp_path / "calibrated.json"
    assert p.path(Output.ROBOT) == tmp_path / "robot.json"
    p.robot = "arms/irb120.json"                 # the robot file is the one project.json names
    assert p.path(Output.ROBOT) == tmp_path / "arms" / "irb120.json"
    assert not p.has(Output.STEREO)
    (tmp_path / "stereo.yaml").write_text("%YAML:1.0\n")
    assert p.has(Output.STEREO)
    assert p.path("poses") == p.path(Output.POSES)       # the short name, as WizardState.outputSaved carries it
    with pytest.raises(RoboCalError, match="unknown project output 'nonsense'"):
        p.path("nonsense")


def test_load_robot_without_robot_is_none(tmp_path):
    assert proj.load_robot(proj.create_project(tmp_path)) is None


def test_create_refuses_an_existing_project(tmp_path):
    proj.create_project(tmp_path)
    with pytest.raises(RoboCalError, match="already holds a project") as info:
        proj.create_project(tmp_path)
    assert "Open it instead" in info.value.message


def test_create_refuses_a_file_and_unknown_mode(tmp_path):
    (tmp_path / "f").write_text("x")
    with pytest.raises(RoboCalError, match="not a folder"):
        proj.create_project(tmp_path / "f")
    with pytest.raises(RoboCalError, match="unknown mode"):
        proj.create_project(tmp_path / "p", mode="teleport")
    assert not (tmp_path / "p").exists()


def test_create_in_an_unwritable_place_names_the_folder(tmp_path):
    (tmp_path / "file").write_text("x")
    with pytest.raises(RoboCalError) as info:
        proj.create_project(tmp_path / "file" / "sub")
    assert "file" in info.value.message


@pytest.mark.parametrize("content, field", [
    ({"format": "robocal.project/2", "name": "x"}, "format"),
    ({"format": "robocal.robot/1", "name": "x"}, "format"),
    ({"name": "x"}, "format"),
    ({"format": "robocal.project/1"}, "name"),
    ({"format": "robocal.project/1", "name": "x", "mode": "teleport"}, "mode"),
    ({"format": "robocal.project/1", "name": "x", "robot": "../elsewhere.json"}, "robot"),
    ({"format": "robocal.project/1", "name": "x", "robot": 3}, "robot"),
])
def test_open_rejects_bad_project_files_naming_the_field(tmp_path, content, field):
    (tmp_path / "project.json").write_text(json.dumps(content))
    with pytest.raises(RoboCalError) as info:
        proj.open_project(tmp_path)
    assert info.value.field == field
    assert "project.json" in info.value.message


def test_open_a_folder_that_is_no_project(tmp_path):
    with pytest.raises(RoboCalError, match="project.json is missing"):
        proj.open_project(tmp_path)


def test_missing_robot_file_is_reported(tmp_path, model):
    p = proj.create_project(tmp_path)
    proj.save_robot(p, model)
    (tmp_path / "robot.json").unlink()
    with pytest.raises(RoboCalError, match="robot file is missing"):
        proj.load_robot(proj.open_project(tmp_path))


def test_a_real_cell_is_saved_read_back_and_described(tmp_path):
    robot = {"kind": "serial", "port": "/dev/ttyUSB0", "profile": "grbl_joint_arm"}
    cams = {"kind": "sources", "left": "0", "right": "/data/right"}
    p = proj.create_project(tmp_path / "cell", mode=proj.HARDWARE, robot_connection=robot, cameras=cams)
    back = proj.open_project(tmp_path / "cell")
    assert back.mode == proj.HARDWARE and back.real_cell and not back.teach_mode
    assert back.robot_connection == proj.RobotConnection("serial", "/dev/ttyUSB0", "grbl_joint_arm")
    assert back.cameras == proj.CameraSources("sources", "0", "/data/right")
    saved = json.loads((tmp_path / "cell" / "project.json").read_text())
    assert saved["robot_connection"] == robot and saved["cameras"] == cams     # the file as before
    assert back.describe_cell() == ("a real cell: the serial robot on /dev/ttyUSB0 (grbl_joint_arm), "
                                    "cameras 0 and /data/right")
    proj.save_cell(p, proj.VIRTUAL_LAB)
    lab = proj.open_project(tmp_path / "cell")
    assert lab.mode == proj.VIRTUAL_LAB and lab.describe_cell() == "the virtual lab (simulated robot and cameras)"
    assert lab.robot_connection.to_dict() == robot              # kept for when the cell is real again
    proj.save_cell(lab, proj.HARDWARE, robot_connection={"kind": "teach"})
    teach = proj.open_project(tmp_path / "cell")
    assert teach.teach_mode and "teach mode" in teach.describe_cell()


def test_the_hardware_records_round_trip_through_project_json(tmp_path):
    robot = proj.RobotConnection("serial", "/dev/ttyACM0", "grbl_joint_arm", joint_map="map.json", baud=57600,
                                 speed=40.0)
    cams = proj.CameraSources("sources", "0", "1", settings={"width": 1280, "height": 1024},
                              identity={"left": {"name": "cam A", "bus": "usb-1"}, "right": {"name": "cam B", "bus": ""}})
    proj.create_project(tmp_path / "cell", mode=proj.HARDWARE, robot_connection=robot, cameras=cams)
    saved = json.loads((tmp_path / "cell" / "project.json").read_text())
    assert saved["robot_connection"] == {"kind": "serial", "port": "/dev/ttyACM0", "profile": "grbl_joint_arm",
                                         "joint_map": "map.json", "baud": 57600, "speed": 40.0}
    assert saved["cameras"]["identity"]["left"] == {"name": "cam A", "bus": "usb-1"}
    back = proj.open_project(tmp_path / "cell")
    assert back.robot_connection == robot and back.cameras == cams
    assert proj.RobotConnection.from_dict({"kind": "teach"}) == proj.RobotConnection("teach")


@pytest.mark.parametrize("key, value, field", [
    ("robot_connection", {"kind": "serial", "port": 3}, "robot_connection.port"),
    ("robot_connection", {"kind": "serial", "baud": "fast"}, "robot_connection.baud"),
    ("robot_connection", {"kind": "serial", "speed": True}, "robot_connection.speed"),
    ("robot_connection", ["serial"], "robot_connection"),
    ("cameras", {"kind": "sources", "settings": [1280]}, "cameras.settings"),
    ("cameras", "0 and 1", "cameras"),
])
def test_a_bad_hardware_record_is_refused_naming_the_field(tmp_path, key, value, field):
    (tmp_path / "project.json").write_text(json.dumps({"format": "robocal.project/1", "name": "p", key: value}))
    with pytest.raises(RoboCalError) as err:
        proj.open_project(tmp_path)
    assert err.value.field == field and err.value.source == str(tmp_path / "project.json")
    assert "Setup page" in err.value.message


def test_an_older_project_file_without_a_cell_reads_as_the_virtual_lab(tmp_path):
    (tmp_path / "project.json").write_text('{"format": "robocal.project/1", "name": "old", "robot": null}')
    p = proj.open_project(tmp_path)
    assert p.mode == proj.VIRTUAL_LAB and p.robot_connection is None and p.cameras is None and not p.real_cell


def test_an_unknown_cell_is_refused_naming_the_field(tmp_path):
    p = proj.create_project(tmp_path / "p")
    with pytest.raises(RoboCalError) as err:
        proj.save_cell(p, "factory")
    assert err.value.field == "mode" and "unknown mode 'factory'" in err.value.problem
    assert proj.open_project(tmp_path / "p").mode == proj.VIRTUAL_LAB
