"""The UR kinematics YAML: read with pyyaml and built into a chain with ur_description's own
equations (urdf/ur_macro.xacro: origin xyz/rpy per joint, rotation about z), written here
independently, against the calibrated model's forward kinematics."""
import numpy as np
import pytest
import yaml

from core.compensation.ur_kinematics import ur_kinematics_yaml, write_ur_kinematics
from core.errors import RoboCalError
from core.robot.file import read_robot
from core.robot.model import robot_path


def _rpy(roll, pitch, yaw):
    """URDF's fixed-axis roll, pitch, yaw: Rz(yaw)·Ry(pitch)·Rx(roll)."""
    cr, sr, cp, sp, cy, sy = np.cos(roll), np.sin(roll), np.cos(pitch), np.sin(pitch), np.cos(yaw), np.sin(yaw)
    return np.array([[cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
                     [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
                     [-sp, cp * sr, cp * cr]])


def _origin(xyz, rpy):
    T = np.eye(4)
    T[:3, :3] = _rpy(*rpy)
    T[:3, 3] = xyz
    return T


def _about_z(q):
    T = np.eye(4)
    T[:2, :2] = [[np.cos(q), -np.sin(q)], [np.sin(q), np.cos(q)]]
    return T


def _tool0(kinematics, q):
    """base_link → tool0 as ur_macro.xacro chains it (metres)."""
    T = _origin([0, 0, 0], [0, 0, np.pi])                               # base_link → base_link_inertia
    for name, qi in zip(("shoulder", "upper_arm", "forearm", "wrist_1", "wrist_2", "wrist_3"), q):
        e = kinematics[name]
        T = T @ _origin([e["x"], e["y"], e["z"]], [e["roll"], e["pitch"], e["yaw"]]) @ _about_z(qi)
    T = T @ _origin([0, 0, 0], [0, -np.pi / 2, -np.pi / 2])              # wrist_3_link → flange
    return T @ _origin([0, 0, 0], [np.pi / 2, 0, np.pi / 2])             # flange → tool0


def _calibrated(name, seed):
    """A UR preset with every DH parameter moved as a calibration would (tenths of a degree,
    a few tenths of a millimetre, β on the parallel joints) and the base in a camera frame."""
    model = read_robot(robot_path(name))
    rng = np.random.default_rng(seed)
    for i, j in enumerate(model.joints):
        j.theta += np.deg2rad(rng.normal(0, 0.2))
        j.d += rng.normal(0, 0.3)
        j.a += rng.normal(0, 0.3)
        j.alpha += np.deg2rad(rng.normal(0, 0.2))
        if i in model.parallel_axis_joints() or i == 5:
            j.beta += np.deg2rad(rng.normal(0, 0.2))
    model.base[:3, 3] = [100.0, -50.0, 1200.0]
    return model


@pytest.mark.parametrize("name", ["ur5", "ur3e", "ur10e"])
def test_chain_from_the_yaml_matches_the_calibrated_model(tmp_path, name):
    model = _calibrated(name, seed=hash(name) % 1000)
    path = write_ur_kinematics(model, tmp_path / "kinematics.yaml")
    data = yaml.safe_load(path.read_text())
    kin = data["kinematics"]
    assert set(kin) == {"shoulder", "upper_arm", "forearm", "wrist_1", "wrist_2", "wrist_3", "hash"}
    assert kin["hash"].startswith("calib_")
    flange_offset = _flange_offset(path.read_text())
    rng = np.random.default_rng(1)
    Q = rng.uniform(-np.pi, np.pi, (1000, 6))
    F = model.frames_many(Q)
    # the calibrated model's DH frame 6 in DH frame 0; the YAML's base_link is DH frame 0 turned by π about z
    expected = np.linalg.inv(F[:, 0]) @ F[:, 6]
    base_link_in_frame0 = _about_z(-np.pi)
    got = np.array([base_link_in_frame0 @ _scaled(_tool0(kin, q)) @ flange_offset for q in Q])
    assert np.abs(got[:, :3, 3] - expected[:, :3, 3]).max() <= 1e-6
    assert np.abs(got[:, :3, :3] - expected[:, :3, :3]).max() <= 1e-9


def _scaled(T):
    T = T.copy()
    T[:3, 3] *= 1000.0                # metres → mm
    return T


def _flange_offset(text):
    """The comment line giving the calibrated flange in tool0 (xyz mm, rpy deg)."""
    line = next(l for l in text.splitlines() if "flange lies at" in l)
    xyz = [float(v) for v in line.split("xyz [")[1].split("]")[0].split(",")]
    rpy = [np.deg2rad(float(v)) for v in line.split("rpy [")[1].split("]")[0].split(",")]
    return _origin(xyz, rpy)


def test_nominal_ur5_gives_ur_descriptions_default_file():
    kin = yaml.safe_load(ur_kinematics_yaml(read_robot(robot_path("ur5"))))["kinematics"]
    # config/ur5/default_kinematics.yaml of ur_description (the published UR5 DH)
    default = {"shoulder": [0, 0, 0.089159, 0, 0, 0], "upper_arm": [0, 0, 0, 1.570796327, 0, 0],
               "forearm": [-0.425, 0, 0, 0, 0, 0], "wrist_1": [-0.39225, 0, 0.10915, 0, 0, 0],
               "wrist_2": [0, -0.09465, 0, 1.570796327, 0, 0]}
    for name, values in default.items():
        got = [kin[name][k] for k in ("x", "y", "z", "roll", "pitch", "yaw")]
        assert np.allclose(got, values, atol=1e-9), name
    # wrist_3: ur_description writes roll π/2, pitch π, yaw π — the same rotation as roll −π/2
    w3 = kin["wrist_3"]
    assert np.allclose(_origin([w3["x"], w3["y"], w3["z"]], [w3["roll"], w3["pitch"], w3["yaw"]]),
                       _origin([0, 0.0823, 0], [1.570796326589793, np.pi, np.pi]), atol=1e-9)


def test_not_a_ur_arm():
    with pytest.raises(RoboCalError, match="not a Universal Robots arm"):
        ur_kinematics_yaml(read_robot(robot_path("bcn3d_moveo")))
    with pytest.raises(RoboCalError, match="not a Universal Robots arm"):
        ur_kinematics_yaml(read_robot(robot_path("puma560")))

