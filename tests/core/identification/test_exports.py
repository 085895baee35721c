"""Exports: the URDF's forward kinematics (parsed by yourdfpy) equals ours, with the robot's own
joint names; names that XML or CSV would choke on; the DH table CSV read back by Python's csv."""
from __future__ import annotations

import csv
import io
import re
import xml.etree.ElementTree as ET

import numpy as np
import pytest

from core import transforms as tf
from core.errors import RoboCalError
from core.identification.exports import (CSV_COLUMNS, dh_table_csv, export_model, target_links, urdf_names,
                                        urdf_text)
from core.kinematics.identifiability import random_configurations
from core.identification.solver import identify
from core.robot.model import PRISMATIC, Joint, RobotModel, robot_path
from core.robot.file import read_robot
from core.virtual_lab.synthetic import perturbed_model, simulate_measurements

yourdfpy = pytest.importorskip("yourdfpy")

PRESETS = ["educational_6r", "puma560", "ur5", "abb_irb120"]


def load_urdf(tmp_path, model):
    path = export_model(model, "urdf", tmp_path / "robot.urdf")
    return yourdfpy.URDF.load(str(path), load_meshes=False, build_collision_scene_graph=False)


def max_fk_difference_mm(urdf, model, n=25, seed=0):
    Q = random_configurations(model, n, seed)
    names = urdf_names(model).joints
    links = target_links(model)
    worst = 0.0
    to_urdf = np.where(model.revolute_mask(), 1.0, 1e-3)      # rad stay rad, mm become m
    for q in Q:
        urdf.update_cfg(dict(zip(names, q * to_urdf)))
        frames = model.frames_many(q[None])[0]
        for i in range(model.dof):
            T = urdf.get_transform(f"link{i + 1}", "world")
            worst = max(worst, np.abs(T[:3, 3] * 1000.0 - frames[i + 1, :3, 3]).max(),
                        1000.0 * np.abs(T[:3, :3] - frames[i + 1, :3, :3]).max())   # rotation as mm at 1 m
        T = urdf.get_transform("tool", "world")
        worst = max(worst, np.abs(T[:3, 3] * 1000.0 - frames[-1, :3, 3]).max())
        for target, link in links.items():
            T = urdf.get_transform(link, "world")
            worst = max(worst, np.abs(T[:3, 3] * 1000.0 - model.target_position(q, target)).max())
    return worst


@pytest.mark.parametrize("name", PRESETS)
def test_urdf_forward_kinematics_equals_ours(tmp_path, name):
    nominal = read_robot(robot_path(name))
    assert max_fk_difference_mm(load_urdf(tmp_path, nominal), nominal) < 1e-6
    perturbed = perturbed_model(nominal, 3, angle_deg=2.0)        # β ≠ 0 on the parallel axes
    for j in perturbed.joints:
        j.beta += 0.02                                             # and on every other joint
    perturbed.tool = tf.pose_to_matrix([5.0, -3.0, 12.0], [0.2, -0.1, 0.4])
    perturbed.targets["probe tip"] = np.array([10.0, 20.0, 30.0])
    urdf = load_urdf(tmp_path, perturbed)
    assert max_fk_difference_mm(urdf, perturbed) < 1e-6
    assert "probe_tip" in urdf.link_map


def test_urdf_prismatic_joint_limits_and_units(tmp_path):
    model = RobotModel("gantry", [
        Joint(type=PRISMATIC, theta=0.3, d=100.0, a=20.0, alpha=np.pi / 2, beta=0.01, min=-50.0, max=400.0),
        Joint(theta=0.1, d=30.0, a=200.0, alpha=0.0, min=-2.0, max=2.0)],
        base=tf.pose_to_matrix([100.0, 200.0, 900.0], [1.0, 0.2, -0.5]), targets={"marker": np.array([1.0, 2.0, 3.0])})
    urdf = load_urdf(tmp_path, model)
    assert max_fk_difference_mm(urdf, model) < 1e-6
    assert urdf.actuated_joint_names == ["J1", "J2"]                # the model's joints have no names
    j1, j2 = urdf.joint_map["J1"], urdf.joint_map["J2"]
    assert j1.type == "prismatic" and j1.limit.lower == pytest.approx(-0.05) and j1.limit.upper == pytest.approx(0.4)
    assert j2.type == "revolute" and j2.limit.lower == pytest.approx(-2.0) and j2.limit.upper == pytest.approx(2.0)
    text = urdf_text(model)
    assert text.startswith('<?xml version="1.0"?>') and 'name="gantry"' in text


def test_urdf_of_a_calibrated_model(tmp_path):
    nominal = read_robot(robot_path("ur5"))
    result = identify(nominal, simulate_measurements(perturbed_model(nominal, 1), 40, rng=2))
    assert max_fk_difference_mm(load_urdf(tmp_path, result.model), result.model) < 1e-6


UR_JOINTS = ["shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint", "wrist_1_joint", "wrist_2_joint",
             "wrist_3_joint"]


def test_urdf_uses_the_robots_joint_names(tmp_path):
    ur5 = read_robot(robot_path("ur5"))
    assert [j.name for j in ur5.joints] == UR_JOINTS
    urdf = load_urdf(tmp_path, ur5)
    assert urdf.actuated_joint_names == UR_JOINTS
    root = ET.fromstring(urdf_text(ur5))
    moving = [j.get("name") for j in root.iter("joint") if j.get("type") != "fixed"]
    assert moving == UR_JOINTS
    assert [j.find("child").get("link") for j in root.iter("joint") if j.get("type") != "fixed"] == \
        [f"{n}_moving" for n in UR_JOINTS]
    assert {"world", "base_link", "tool", "marker"} | {f"link{i}" for i in range(1, 7)} <= \
        {link.get("name") for link in root.iter("link")}
    assert max_fk_difference_mm(urdf, ur5) < 1e-6


def test_urdf_names_are_sanitised_and_unique(tmp_path):
    model = read_robot(robot_path("educational_6r"))
    for j, name in zip(model.joints, ["shoulder pan", "shoulder-pan", "", "3rd", "tool_joint", "J1"]):
        j.name = name
    model.targets = {"tool": np.array([0.0, 0.0, 10.0]), "shoulder_pan": np.array([1.0, 0.0, 0.0]),
                     "marker": np.array([0.0, 1.0, 0.0])}
    names = urdf_names(model)
    assert names.joints == ["shoulder_pan", "shoulder_pan_2", "J3", "_3rd", "tool_joint", "J1"]
    assert names.target_links == {"tool": "target_tool", "shoulder_pan": "shoulder_pan", "marker": "marker"}
    root = ET.fromstring(urdf_text(model))
    joints = [j.get("name") for j in root.iter("joint")]
    links = [link.get("name") for link in root.iter("link")]
    assert len(set(joints)) == len(joints) and len(set(links)) == len(links)
    assert "tool_joint_2" in joints and "shoulder_pan_joint" in joints          # fixed ones give way
    urdf = load_urdf(tmp_path, model)
    assert urdf.actuated_joint_names == names.joints
    assert max_fk_difference_mm(urdf, model) < 1e-6


def test_awkward_names_make_valid_files(tmp_path):
    model = read_robot(robot_path("educational_6r"))
    model.name = 'arm -- "B" <2> & co-\x01\nline two-'
    model.joints[1].name = "elbow,\nsecond \"row\""
    model.joints[2].name = "wrist\rthree"
    model.targets = {"mark<er>\n": np.array([0.0, 0.0, 40.0])}
    text = urdf_text(model)
    root = ET.fromstring(text)                                     # a `--` in a comment would not parse
    assert root.get("name") == 'arm -- "B" <2> & co-\nline two-'   # control characters dropped, rest kept
    assert urdf_names(model).joints[1] == "elbow__second__row_"
    urdf = load_urdf(tmp_path, model)
    assert urdf.robot.name == root.get("name") and "mark_er__" in urdf.link_map
    assert max_fk_difference_mm(urdf, model) < 1e-6
    rows = list(csv.reader(io.StringIO(export_model(model, "dh-csv", tmp_path / "dh.csv").read_bytes().decode(),
                                       newline="")))
    assert len(rows) == 7 and all(len(r) == len(CSV_COLUMNS) for r in rows)
    assert rows[2][0] == "elbow,\nsecond \"row\"" and rows[3][0] == "wrist\rthree"


def read_csv(text):
    return list(csv.DictReader(io.StringIO(text, newline="")))


def test_dh_table_csv_nominal_and_calibrated(tmp_path):
    nominal = read_robot(robot_path("educational_6r"))
    text = dh_table_csv(nominal)
    rows = read_csv(text)
    assert list(rows[0]) == CSV_COLUMNS and len(rows) == 6 and text.count("\r\n") == 7
    assert all(re.search(r"_(mm|deg)$", c) for c in CSV_COLUMNS[2:])   # every number has its unit
    assert rows[1] == {"joint": "J2", "type": "revolute", "theta_deg": "90", "d_mm": "0", "a_mm": "120",
                       "alpha_deg": "0", "beta_deg": "0", "min_deg": "-100", "max_deg": "100", "min_mm": "",
                       "max_mm": "", "theta_std_deg": "", "d_std_mm": "", "a_std_mm": "", "alpha_std_deg": "",
                       "beta_std_deg": ""}
    result = identify(nominal, simulate_measurements(perturbed_model(nominal, 1), 40, rng=2))
    text = dh_table_csv(result.model)
    rows = read_csv(text)
    assert list(rows[0]) == CSV_COLUMNS
    assert float(rows[1]["a_mm"]) == pytest.approx(result.model.joints[1].a, abs=1e-6)
    assert float(rows[1]["a_std_mm"]) == pytest.approx(result.row("J2.a").std, rel=1e-6)
    assert float(rows[1]["beta_std_deg"]) > 0                   # J2.beta estimated (Hayati)
    assert rows[1]["d_std_mm"] == ""                             # J2.d fixed: no std
    assert rows[0]["theta_std_deg"] == ""                        # J1.theta absorbed by the base
    path = export_model(result.model, "dh-csv", tmp_path / "dh.csv")
    assert path.read_bytes().decode() == text


def test_dh_table_csv_prismatic_limits_in_mm():
    model = RobotModel("gantry", [
        Joint(type=PRISMATIC, theta=0.0, d=100.0, a=20.0, alpha=np.pi / 2, min=-50.0, max=400.0, name="rail"),
        Joint(theta=0.1, d=30.0, a=200.0, alpha=0.0, min=-2.0, max=2.0)])
    rows = read_csv(dh_table_csv(model))
    assert [r["joint"] for r in rows] == ["rail", "J2"]
    assert (rows[0]["min_deg"], rows[0]["max_deg"], rows[0]["min_mm"], rows[0]["max_mm"]) == ("", "", "-50", "400")
    assert float(rows[1]["max_deg"]) == pytest.approx(np.rad2deg(2.0)) and rows[1]["max_mm"] == ""


def test_unknown_export_format(tmp_path):
    nominal = read_robot(robot_path("educational_6r"))
    with pytest.raises(RoboCalError, match="unknown export format"):
        export_model(nominal, "sdf", tmp_path / "x.sdf")


def test_exports_say_they_cannot_hold_deflection_terms(tmp_path):
    from core.robot.compliance import Compliance

    model = read_robot(robot_path("abb_irb120"))
    assert "deflection" not in dh_table_csv(model) and "deflection" not in urdf_text(model)
    model.compliance = Compliance.zero(model.dof)
    model.compliance.set(1, "cos_q2", np.deg2rad(0.05))
    text = dh_table_csv(model)
    first, rest = text.split("\r\n", 1)
    assert first.startswith("# ") and "deflection terms (J2, J3" in first and "robot JSON file" in first
    rows = list(csv.reader(io.StringIO(rest)))
    assert rows[0] == CSV_COLUMNS and len(rows) == 7
    root = ET.fromstring(urdf_text(model).split("\n", 1)[1])          # parses: the note is a comment
    assert root.tag == "robot"
    assert "<!-- This model also has deflection terms (J2, J3 bend under the arm's weight)" in urdf_text(model)
