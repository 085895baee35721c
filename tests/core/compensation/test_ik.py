"""Inverse kinematics against forward kinematics: every preset, frames, branches, limits,
unreachable targets, a prismatic joint, orientation."""
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from core import transforms as tf
from core.compensation.ik import solve_ik, tcp_poses
from core.errors import UsageError
from core.robot.file import read_robot
from core.robot.model import PRISMATIC, REVOLUTE, Joint, RobotModel, preset_names, robot_path


def _well_conditioned(model, Q, tcp):
    """Configurations whose 6 x n geometric Jacobian (rotations × the arm's length) keeps its
    smallest singular value above 1 % of the largest: away from singular arms, where a target
    on the fold of the workspace converges only linearly."""
    F = model.frames_many(Q)
    T = tcp_poses(model, Q, tcp)
    n = model.dof
    L = sum(abs(j.a) + abs(j.d) for j in model.joints)
    keep = []
    for k in range(len(Q)):
        cols = []
        for i in range(n):
            z, o = F[k, i, :3, 2], F[k, i, :3, 3]
            if model.joints[i].revolute:
                cols.append(np.r_[np.cross(z, T[k, :3, 3] - o), L * z])
            else:
                cols.append(np.r_[z, np.zeros(3)])
        s = np.linalg.svd(np.array(cols).T, compute_uv=False)
        keep.append(s[min(n, 6) - 1] > 0.01 * s[0])
    return np.array(keep)


def _angle_deg(A, B):
    """Angles (deg) between the rotations of poses A and B (N, 4, 4) (rotation vectors: exact
    for small angles, unlike an arccos of the trace)."""
    return np.rad2deg(Rotation.from_matrix(A[:, :3, :3] @ np.swapaxes(B[:, :3, :3], 1, 2)).magnitude())


def _random_configs(model, N, seed):
    lo, hi = model.sampling_range()
    rng = np.random.default_rng(seed)
    Q = lo + (hi - lo) * rng.random((N, model.dof))
    return Q[_well_conditioned(model, Q, "marker")]


@pytest.mark.parametrize("name", preset_names())
def test_round_trip_every_preset(name):
    model = read_robot(robot_path(name))
    Q = _random_configs(model, 300, seed=1)
    assert len(Q) > 150
    T = tcp_poses(model, Q, "marker")
    rng = np.random.default_rng(2)
    hint = Q + rng.normal(0.0, 0.05, Q.shape)
    if model.dof >= 6:
        res = solve_ik(model, T[:, :3, 3], T[:, :3, :3], tcp="marker", frame="measurement", hint=hint)
    else:   # a 5-axis arm cannot take an arbitrary orientation: position only
        res = solve_ik(model, T[:, :3, 3], tcp="marker", frame="measurement", hint=hint)
    assert res.ok.all(), [r for r in res.reason if r][:3]
    assert model.within_limits(res.Q).all()
    got = tcp_poses(model, res.Q, "marker")
    assert np.linalg.norm(got[:, :3, 3] - T[:, :3, 3], axis=1).max() <= 1e-6
    if model.dof >= 6:
        assert _angle_deg(got, T).max() <= 1e-6
        # the hint is 0.05 rad from the configuration that made the target: the solver lands there
        assert np.abs(res.Q - Q).max() < 1e-6
    assert np.allclose(res.error_mm, np.linalg.norm(got[:, :3, 3] - T[:, :3, 3], axis=1), atol=1e-12)


def _ur5_with_base():
    model = read_robot(robot_path("ur5"))
    model.base = tf.pose_to_matrix([120.0, -40.0, 900.0], np.deg2rad([170.0, 5.0, -30.0]))
    return model


def test_frames_base_measurement_and_fixture():
    model = _ur5_with_base()
    Q = _random_configs(model, 20, seed=3)
    world = tcp_poses(model, Q, "marker")
    in_base = tf.invert(model.base) @ world
    fixture = tf.pose_to_matrix([300.0, 50.0, 20.0], np.deg2rad([0.0, 0.0, 35.0]))
    in_fixture = tf.invert(model.base @ fixture) @ world
    for targets, frame in ((world, "measurement"), (world, "camera"), (in_base, "base"), (in_fixture, fixture)):
        res = solve_ik(model, targets[:, :3, 3], targets[:, :3, :3], frame=frame, hint=Q + 0.02)
        assert res.ok.all()
        assert np.abs(res.Q - Q).max() < 1e-6
    assert solve_ik(model, in_fixture[:1, :3, 3], frame=fixture, hint=Q[:1]).frame == "fixture"


def test_hint_picks_the_branch():
    model = read_robot(robot_path("ur5"))
    elbow_up = np.deg2rad([20.0, -70.0, 80.0, -100.0, -90.0, 10.0])
    T = tcp_poses(model, elbow_up[None], "marker")
    # the other elbow: start with joint 3 mirrored and let the solver find the exact configuration
    flipped = elbow_up.copy()
    flipped[2] *= -1
    flipped[1] += np.deg2rad(70.0)
    other = solve_ik(model, T[:, :3, 3], T[:, :3, :3], frame="measurement", hint=flipped[None])
    assert other.ok[0]
    elbow_down = other.Q[0]
    assert np.sign(elbow_down[2]) != np.sign(elbow_up[2])
    assert np.allclose(tcp_poses(model, elbow_down[None], "marker"), T, atol=1e-6)
    for truth in (elbow_up, elbow_down):
        res = solve_ik(model, T[:, :3, 3], T[:, :3, :3], frame="measurement", hint=(truth + 0.1)[None])
        assert res.ok[0]
        assert np.abs(res.Q[0] - truth).max() < 1e-6


def test_without_hint_a_path_follows_the_previous_point():
    model = read_robot(robot_path("abb_irb120"))
    s = np.linspace(0.0, 1.0, 60)[:, None]
    a, b = np.deg2rad([-40.0, 10.0, 5.0, 30.0, 40.0, 0.0]), np.deg2rad([40.0, 30.0, -20.0, -30.0, 60.0, 90.0])
    Q = a + s * (b - a)
    T = tcp_poses(model, Q, "marker")
    res = solve_ik(model, T[:, :3, 3], T[:, :3, :3], frame="measurement", start=a)
    assert res.ok.all()
    steps = np.abs(np.diff(res.Q, axis=0)).max()
    assert steps < 2.0 * np.abs(np.diff(Q, axis=0)).max()
    assert np.abs(res.Q - Q).max() < 1e-6


def test_a_solution_outside_the_limits_is_reported_not_clipped():
    model = read_robot(robot_path("ur5"))
    q = np.deg2rad([50.0, -70.0, 80.0, -100.0, -90.0, 10.0])
    T = tcp_poses(model, q[None], "marker")
    narrow = model.copy()
    narrow.joints[0].min, narrow.joints[0].max = np.deg2rad(-30.0), np.deg2rad(30.0)
    # joint 1 alone turns the arm about the vertical: with it within ±30° the marker cannot get there
    res = solve_ik(narrow, T[:, :3, 3], T[:, :3, :3], frame="measurement", hint=q[None])
    assert not res.ok[0]
    assert res.reason[0].startswith("outside the joint limits: q1 would be 50.00°")
    assert np.allclose(res.Q[0], q, atol=1e-9)           # the solution itself, not clipped
    free = solve_ik(model, T[:, :3, 3], T[:, :3, :3], frame="measurement", hint=q[None])
    assert free.ok[0] and free.reason == [""]


def test_limits_choose_the_solution_inside_when_there_is_one():
    model = read_robot(robot_path("ur5"))
    q = np.deg2rad([10.0, -70.0, 80.0, -100.0, -90.0, 170.0])
    T = tcp_poses(model, q[None], "marker")
    narrow = model.copy()
    narrow.joints[5].min, narrow.joints[5].max = np.deg2rad(-200.0), np.deg2rad(-180.0)
    # the same wrist angle a turn lower (−190°) is inside the limits
    res = solve_ik(narrow, T[:, :3, 3], T[:, :3, :3], frame="measurement", hint=q[None])
    assert res.ok[0]
    assert np.rad2deg(res.Q[0, 5]) == pytest.approx(-190.0, abs=1e-6)


def test_an_unreachable_target_is_named_with_its_distance():
    model = read_robot(robot_path("educational_6r"))
    q = np.zeros(6)
    p = tcp_poses(model, q[None], "marker")[0, :3, 3]
    far = p * 0 + np.array([5000.0, 0.0, 0.0])
    targets = np.array([p, far])
    res = solve_ik(model, targets, frame="measurement", hint=np.zeros((2, 6)))
    assert res.ok.tolist() == [True, False]
    assert res.reason[1].startswith("out of reach: the tool point stays")
    # the closest a 6R arm of this size comes is its reach: the gap is at least 5000 − reach
    reach = sum(abs(j.a) + abs(j.d) for j in model.joints) + np.linalg.norm(model.targets["marker"])
    assert res.error_mm[1] >= 5000.0 - reach - np.linalg.norm(model.base[:3, 3])
    assert f"{res.error_mm[1]:.3g} mm" in res.reason[1]


def _scara():
    """A SCARA arm: two revolute joints, a vertical prismatic joint, a wrist."""
    return RobotModel("scara", [
        Joint(REVOLUTE, d=400.0, a=325.0, min=-np.deg2rad(150), max=np.deg2rad(150)),
        Joint(REVOLUTE, a=275.0, alpha=np.pi, min=-np.deg2rad(140), max=np.deg2rad(140)),
        Joint(PRISMATIC, d=0.0, min=0.0, max=200.0),
        Joint(REVOLUTE, d=30.0, min=-np.pi, max=np.pi)],
        targets={"marker": np.array([20.0, 0.0, 15.0])})


def test_prismatic_joint_round_trip():
    model = _scara()
    rng = np.random.default_rng(5)
    lo, hi = model.limits()
    Q = lo + (hi - lo) * rng.random((200, 4))
    Q = Q[np.abs(Q[:, 1]) > 0.2]                           # away from the stretched arm
    T = tcp_poses(model, Q, "marker")
    res = solve_ik(model, T[:, :3, 3], frame="measurement", hint=Q + np.array([0.05, 0.05, 5.0, 0.05]))
    assert res.ok.all()
    got = tcp_poses(model, res.Q, "marker")[:, :3, 3]
    assert np.linalg.norm(got - T[:, :3, 3], axis=1).max() <= 1e-6
    # a height above the prismatic stroke is out of the limits
    high = T[:1, :3, 3] + [0.0, 0.0, 500.0]
    res = solve_ik(model, high, frame="measurement", hint=Q[:1])
    assert not res.ok[0] and "q3" in res.reason[0] and "mm" in res.reason[0]


def test_orientation_of_the_tool_frame():
    model = read_robot(robot_path("kuka_kr6_r900"))
    model.tool = tf.pose_to_matrix([0.0, 0.0, 120.0], np.deg2rad([0.0, 30.0, 0.0]))
    Q = _random_configs(model, 40, seed=7)
    T = tcp_poses(model, Q, "tool")
    assert np.allclose(T, model.fk_many(Q))
    res = solve_ik(model, T[:, :3, 3], T[:, :3, :3], tcp="tool", frame="measurement", hint=Q - 0.05)
    assert res.ok.all() and res.orientation
    got = model.fk_many(res.Q)
    assert _angle_deg(got, T).max() <= 1e-6
    assert res.error_deg.max() <= 1e-6
    # the same positions with the tool turned 90° about its z axis: another configuration
    turned = T[:, :3, :3] @ tf.rot_z(np.pi / 2)
    res2 = solve_ik(model, T[:, :3, 3], turned, tcp="tool", frame="measurement", hint=Q)
    ok = res2.ok
    assert ok.sum() > len(Q) // 2
    got2 = model.fk_many(res2.Q[ok])
    assert np.allclose(got2[:, :3, :3], turned[ok], atol=1e-9)


def test_marker_orientation_on_the_tool_counts():
    model = read_robot(robot_path("ur5"))
    model.target_rotations["marker"] = tf.rot_x(np.deg2rad(20.0))
    Q = _random_configs(model, 10, seed=8)
    T = tcp_poses(model, Q, "marker")
    assert np.allclose(T[:, :3, :3], model.fk_many(Q)[:, :3, :3] @ tf.rot_x(np.deg2rad(20.0)))
    res = solve_ik(model, T[:, :3, 3], T[:, :3, :3], frame="measurement", hint=Q + 0.03)
    assert res.ok.all() and np.abs(res.Q - Q).max() < 1e-6


def test_bad_calls():
    model = read_robot(robot_path("ur5"))
    with pytest.raises(UsageError, match="no tool point 'gripper'.*tool, marker"):
        solve_ik(model, np.zeros((1, 3)), tcp="gripper")
    with pytest.raises(UsageError, match="unknown frame"):
        solve_ik(model, np.zeros((1, 3)), frame="world")
    with pytest.raises(UsageError, match=r"\(N, 3\)"):
        solve_ik(model, np.zeros(3))
    with pytest.raises(UsageError, match="hint"):
        solve_ik(model, np.zeros((2, 3)), hint=np.zeros((1, 6)))
    assert len(solve_ik(model, np.zeros((0, 3)))) == 0
