"""Forward kinematics of the presets against hand-derived values, and model properties.

The expected positions were derived on paper from the published DH tables (frame by frame,
A = Rz(θ)·Tz(d)·Tx(a)·Rx(α)); the zero poses also match published references:
PUMA 560 (Corke's p560 at qz: 452.12, -150.05, 431.8 mm), UR5 (-817.25, -191.45, -5.491 mm),
ABB IRB 120 (product specification: wrist flange at x = 374, z = 630 mm).
"""
import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from core import transforms as tf
from core.robot.model import Joint, RobotModel, dh_matrices, preset_names, robot_path
from core.robot.file import read_robot

HAND_CHECKED = {
    # preset: [(q in degrees, flange position mm), ...]
    "educational_6r": [
        ([0, 0, 0, 0, 0, 0], [200.0, 0.0, 230.0]),
        ([0, -90, 0, 0, 0, 0], [120.0, 0.0, -90.0]),
        ([90, 0, 0, 0, 0, 0], [0.0, 200.0, 230.0]),
    ],
    "puma560": [
        ([0, 0, 0, 0, 0, 0], [452.12, -150.05, 431.8]),
        ([90, 0, 0, 0, 0, 0], [150.05, 452.12, 431.8]),
        ([0, 90, 0, 0, 0, 0], [-431.8, -150.05, 452.12]),
    ],
    "ur5": [
        ([0, 0, 0, 0, 0, 0], [-817.25, -191.45, -5.491]),
        ([90, 0, 0, 0, 0, 0], [191.45, -817.25, -5.491]),
        ([0, -90, 0, 0, 0, 0], [-94.65, -191.45, 906.409]),
    ],
    "abb_irb120": [
        ([0, 0, 0, 0, 0, 0], [374.0, 0.0, 630.0]),
        ([90, 0, 0, 0, 0, 0], [0.0, 374.0, 630.0]),
        ([0, 90, 0, 0, 0, 0], [340.0, 0.0, -84.0]),
    ],
    # UR e-Series: x = a2 + a3, y = −(d4 + d6), z = d1 − d5 of UR's published DH
    "ur3e": [
        ([0, 0, 0, 0, 0, 0], [-456.75, -223.15, 66.5]),
        ([90, 0, 0, 0, 0, 0], [223.15, -456.75, 66.5]),
    ],
    "ur10e": [
        ([0, 0, 0, 0, 0, 0], [-1184.25, -290.7, 60.85]),
        ([90, 0, 0, 0, 0, 0], [290.7, -1184.25, 60.85]),
    ],
    # UFACTORY's zero position of the xArm 6: flange at (207, 0, 112) mm
    "xarm6": [
        ([0, 0, 0, 0, 0, 0], [207.0, 0.0, 112.0]),
        ([90, 0, 0, 0, 0, 0], [0.0, 207.0, 112.0]),
    ],
    # KUKA KR 6 R900 sixx stretched out: x = 25 + 455 + 420 + 80, z = 400 + 35; A1 turns clockwise seen from
    # above; at KUKA's home (A2 −90°, A3 90°) the upper arm is vertical: x = 25 + 420 + 80, z = 400 + 455 + 35
    "kuka_kr6_r900": [
        ([0, 0, 0, 0, 0, 0], [980.0, 0.0, 435.0]),
        ([90, 0, 0, 0, 0, 0], [0.0, -980.0, 435.0]),
        ([0, -90, 90, 0, 0, 0], [525.0, 0.0, 890.0]),
    ],
    # FANUC LR Mate 200iD (ROS-Industrial's chain, base_link on the mounting face): at zero x = 50 + 335 + 80,
    # z = 330 + 330 + 35; joint_2 +90° about +y lays the arm forward and down: x = 50 + 330 + 35, z = 330 − 335 − 80;
    # joint_3 +90° about −y raises the forearm: x = 50 − 35, z = 330 + 330 + 335 + 80
    "fanuc_lrmate200id": [
        ([0, 0, 0, 0, 0, 0], [465.0, 0.0, 695.0]),
        ([0, 90, 0, 0, 0, 0], [415.0, 0.0, -85.0]),
        ([0, 0, 90, 0, 0, 0], [15.0, 0.0, 1075.0]),
    ],
    # myCobot 280 upright: x = 45.6 (J6 to flange), y = −64.62, z = 131.56 + 110.4 + 96 + 73.18; J1 +90° turns it
    # about z; J2 +90° lays the arm towards −x: x = −(110.4 + 96 + 73.18), z = 131.56 + 45.6
    "mycobot_280": [
        ([0, 0, 0, 0, 0, 0], [45.6, -64.62, 411.14]),
        ([90, 0, 0, 0, 0, 0], [64.62, 45.6, 411.14]),
        ([0, 90, 0, 0, 0, 0], [-279.58, -64.62, 177.16]),
    ],
    # Thor upright: z = 99 + 103 + 160 + 89.5 + 104.5 + 13.5; joint_2 +90° about +x lays the arm towards −y from
    # J2 (z = 202): y = −(160 + 194 + 13.5); joint_1 +90° then turns that onto +x
    "thor": [
        ([0, 0, 0, 0, 0, 0], [0.0, 0.0, 569.5]),
        ([0, 90, 0, 0, 0, 0], [0.0, -367.5, 202.0]),
        ([90, 90, 0, 0, 0, 0], [367.5, 0.0, 202.0]),
    ],
    # BCN3D Moveo: its zero is the CAD's bent pose, not derivable on paper; the zero position is yourdfpy's FK of
    # the moveo_ros URDF (tests/data/robots, 1.5708 and 3.1416 read as π/2 and π). J1 turns about the vertical
    # axis through (0, −242.5): +90° maps (120.676276, 72.990884 + 242.5) to (−315.490884, 120.676276) about it.
    "bcn3d_moveo": [
        ([0, 0, 0, 0, 0], [120.676276, 72.990884, 569.16739]),
        ([90, 0, 0, 0, 0], [-315.490884, -121.823724, 569.16739]),
    ],
}
# positions written to 1e-6 mm where they come from a program rather than exact sums
HAND_TOLERANCE_MM = {"bcn3d_moveo": 1e-6}


def test_every_preset_is_hand_checked():
    assert set(preset_names()) == set(HAND_CHECKED)


@pytest.mark.parametrize("name", sorted(HAND_CHECKED))
def test_fk_matches_hand_checked_values(name):
    model = read_robot(robot_path(name))
    for q_deg, expected in HAND_CHECKED[name]:
        T = model.fk(model.q_from_file(q_deg))
        np.testing.assert_allclose(T[:3, 3], expected, atol=HAND_TOLERANCE_MM.get(name, 1e-9))
        np.testing.assert_allclose(T[:3, :3] @ T[:3, :3].T, np.eye(3), atol=1e-12)


@pytest.mark.parametrize("name", sorted(HAND_CHECKED))
def test_vectorised_fk_equals_one_at_a_time(name):
    model = read_robot(robot_path(name))
    lo, hi = model.limits()
    Q = np.random.default_rng(1).uniform(lo, hi, (25, model.dof))
    many = model.fk_many(Q)
    for q, T in zip(Q, many):
        np.testing.assert_allclose(model.fk(q), T, atol=1e-10)
    frames = model.frames_many(Q)
    np.testing.assert_allclose(frames[:, -1], many, atol=1e-10)
    np.testing.assert_allclose(frames[:, 0], np.broadcast_to(model.base, (25, 4, 4)))


def test_base_tool_and_target_compose():
    model = read_robot(robot_path("educational_6r"))
    model.base = tf.pose_to_matrix([10, -20, 700], np.deg2rad([90, 0, 30]))
    model.tool = tf.pose_to_matrix([0, 5, 12], np.deg2rad([0, 15, 0]))
    q = np.deg2rad([10, -30, 40, 5, 60, -20])
    A = np.eye(4)
    for T in model.joint_transforms(q[None])[0]:
        A = A @ T
    expected = model.base @ A @ model.tool
    np.testing.assert_allclose(model.fk(q), expected, atol=1e-10)
    np.testing.assert_allclose(model.target_position(q, "marker"),
                               tf.transform_points(expected, model.targets["marker"][None])[0], atol=1e-10)


def test_prismatic_joint_moves_along_its_axis():
    model = RobotModel("cartesian", [
        Joint(type="prismatic", theta=0.0, d=100.0, a=0.0, alpha=np.pi / 2, min=0, max=500),
        Joint(type="revolute", theta=0.0, d=0.0, a=50.0, alpha=0.0, min=-np.pi, max=np.pi),
    ])
    p0 = model.fk([0.0, 0.0])[:3, 3]
    p1 = model.fk([120.0, 0.0])[:3, 3]
    np.testing.assert_allclose(p1 - p0, [0, 0, 120.0], atol=1e-12)
    np.testing.assert_allclose(p0, [50.0, 0.0, 100.0], atol=1e-12)


def test_units_round_trip_and_limits():
    model = read_robot(robot_path("puma560"))
    q_file = np.array([10.0, -20, 30, 40, -50, 60])
    np.testing.assert_allclose(model.q_to_file(model.q_from_file(q_file)), q_file)
    assert model.within_limits(model.q_from_file(q_file))
    assert not model.within_limits(model.q_from_file([170.0, 0, 0, 0, 0, 0]))


def test_dh_matrix_is_the_product_of_elementary_transforms():
    theta, d, a, alpha, beta = 0.3, 12.0, -40.0, -1.1, 0.02
    expected = (tf.make_transform(tf.rot_z(theta)) @ tf.make_transform(None, [0, 0, d])
                @ tf.make_transform(None, [a, 0, 0]) @ tf.make_transform(tf.rot_x(alpha))
                @ tf.make_transform(tf.rot_y(beta)))
    np.testing.assert_allclose(dh_matrices(theta, d, a, alpha, beta), expected, atol=1e-14)


def test_parallel_axes_are_found():
    assert read_robot(robot_path("ur5")).parallel_axis_joints() == [1, 2]
    assert read_robot(robot_path("puma560")).parallel_axis_joints() == [1]


def _two_parallel_axes(beta: float) -> RobotModel:
    return RobotModel("planar", [
        Joint(theta=0.0, d=0.0, a=300.0, alpha=0.0, beta=beta),
        Joint(theta=0.0, d=0.0, a=250.0, alpha=0.0),
    ], targets={"tip": np.array([0.0, 0.0, 80.0])})


def test_hayati_beta_is_continuous_near_parallel_axes():
    """A tiny tilt β of a nearly parallel axis moves the tip by O(β·reach): the model stays
    smooth through β = 0, where plain DH would need the common normal (d) to jump."""
    q = np.deg2rad([20.0, -35.0])
    p0 = _two_parallel_axes(0.0).target_position(q, "tip")
    for beta in (1e-6, -1e-6, 1e-4, -1e-4, 1e-3):
        p = _two_parallel_axes(beta).target_position(q, "tip")
        assert np.linalg.norm(p - p0) <= 1.01 * abs(beta) * 400.0  # reach of the rest of the arm
    h = 1e-7
    slope_left = (_two_parallel_axes(0.0).target_position(q, "tip")
                  - _two_parallel_axes(-h).target_position(q, "tip")) / h
    slope_right = (_two_parallel_axes(h).target_position(q, "tip")
                   - _two_parallel_axes(0.0).target_position(q, "tip")) / h
    np.testing.assert_allclose(slope_left, slope_right, atol=1e-4)
    assert np.linalg.norm(slope_right) > 1.0  # β really acts (it is identifiable)


@settings(max_examples=40, deadline=None)
@given(st.lists(st.floats(-3.0, 3.0), min_size=3, max_size=3))
def test_rpy_round_trip(rpy):
    rpy = np.array(rpy)
    rpy[1] = np.clip(rpy[1], -1.5, 1.5)
    R = tf.rpy_to_matrix(rpy)
    np.testing.assert_allclose(tf.rpy_to_matrix(tf.matrix_to_rpy(R)), R, atol=1e-9)
    T = tf.pose_to_matrix([1, 2, 3], rpy)
    np.testing.assert_allclose(tf.invert(T) @ T, np.eye(4), atol=1e-12)


def test_sampling_range_keeps_each_joints_units():
    model = RobotModel("gantry", [
        Joint(type="prismatic", d=0.0, alpha=np.pi / 2, min=0.0, max=300.0),
        Joint(type="revolute", a=50.0, min=-np.deg2rad(270), max=np.deg2rad(270)),
    ])
    lo, hi = model.sampling_range(5.0)
    np.testing.assert_allclose(lo, [5.0, -np.pi + np.deg2rad(5)])     # 5 mm, and 5° inside ±180°
    np.testing.assert_allclose(hi, [295.0, np.pi - np.deg2rad(5)])
    from core.kinematics.identifiability import random_configurations
    Q = random_configurations(model, 500, seed=1)
    assert Q[:, 0].max() > 200.0 and Q[:, 0].min() >= 0.0            # the whole prismatic stroke


def test_rotation_helpers_agree_with_opencv():
    import cv2
    rng = np.random.default_rng(5)
    for omega in list(rng.normal(0, 1.0, (20, 3))) + [np.array([1e-14, 0, 0]), np.zeros(3)]:
        np.testing.assert_allclose(tf.rot_vec(omega), cv2.Rodrigues(omega)[0], atol=1e-12)
        angle = np.linalg.norm(omega)
        if angle > 1e-6:
            np.testing.assert_allclose(tf.rot_axis(3.0 * omega, angle), tf.rot_vec(omega), atol=1e-12)
            if angle < np.pi:
                assert abs(tf.rotation_angle(tf.rot_vec(omega)) - angle) < 1e-6
