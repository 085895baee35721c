"""The virtual lab set-up: true robot errors, stereo rig, marker description, the lab's robot placement, robot poses and board poses."""
from __future__ import annotations

import numpy as np
import pytest

from core import transforms as tf
from core.robot.model import preset_names, robot_path
from core.robot.file import read_robot, robot_from_dict, robot_to_dict
from core.virtual_lab.lab import BOARD_DEPTH, BOARD_MARGIN_PX, VirtualLab
from core.marker.description import MarkerDescription
from core.virtual_lab.rig import default_rig, rig_to_dict
from core.virtual_lab.robot_errors import perturb_robot

PRESETS = preset_names()
DEG = np.pi / 180


@pytest.mark.parametrize("name", PRESETS)
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_error_magnitudes_within_stated_ranges(name, seed):
    nominal = read_robot(robot_path(name))
    errs = perturb_robot(nominal, seed)
    true = errs.robot
    p0, p1 = nominal.dh_arrays(), true.dh_arrays()
    for key, (lo, hi) in (("d", (0.5, 2.0)), ("a", (0.5, 2.0)), ("theta", (0.1 * DEG, 0.5 * DEG)),
                          ("alpha", (0.1 * DEG, 0.5 * DEG)), ("beta", (0.1 * DEG, 0.5 * DEG))):
        delta = p1[key] - p0[key]
        assert np.allclose(delta, errs.delta[key])
        mask = errs.perturbed[key]
        assert np.all((np.abs(delta[mask]) >= lo - 1e-12) & (np.abs(delta[mask]) <= hi + 1e-12)), key
        assert np.all(delta[~mask] == 0.0), key
    parallel = nominal.parallel_axis_joints()
    assert errs.perturbed["beta"].tolist() == [i in parallel for i in range(nominal.dof)]
    for i in parallel:              # Hayati: d_i beside beta_i is kept (redundant with d_(i+1))
        assert not errs.perturbed["d"][i]
    for name_t, p in nominal.targets.items():
        assert 0.5 <= np.linalg.norm(true.targets[name_t] - p) <= 1.5
    assert np.array_equal(true.base, nominal.base) and np.array_equal(true.tool, nominal.tool)
    # Both signs occur over the parameters (not a systematic offset).
    allv = np.concatenate([errs.delta[k][errs.perturbed[k]] for k in ("d", "a", "theta", "alpha")])
    assert (allv > 0).any() and (allv < 0).any()


def test_errors_are_seeded():
    nominal = read_robot(robot_path("educational_6r"))
    a, b, c = perturb_robot(nominal, 7), perturb_robot(nominal, 7), perturb_robot(nominal, 8)
    assert robot_to_dict(a.robot) == robot_to_dict(b.robot)
    assert robot_to_dict(a.robot) != robot_to_dict(c.robot)
    # The nominal model is left untouched.
    assert robot_to_dict(nominal) == robot_to_dict(read_robot(robot_path("educational_6r")))


def test_default_rig():
    rig = default_rig(0)
    for cam in (rig.left, rig.right):
        assert cam.size == (1280, 1024)
        assert 1480 < cam.fx < 1520 and abs(cam.fy / cam.fx - 1) < 1e-3
        assert 0.5 < abs(cam.cx - 639.5) < 6.01 or 0.5 < abs(cam.cy - 511.5) < 6.01
        assert abs(cam.cx - 639.5) <= 6.01 and abs(cam.cy - 511.5) <= 6.01
        assert -0.09 < cam.dist[0] < -0.07 and 0.04 < cam.dist[1] < 0.06
        assert np.all(np.abs(cam.dist[2:4]) < 1e-3)
    assert abs(rig.baseline - 130.0) < 1.5
    assert np.allclose(rig.T, [-130.0, 0.0, 0.0], atol=1.5)
    angle = np.rad2deg(tf.rotation_angle(rig.R))
    assert 0.2 <= angle <= 0.5
    assert np.linalg.norm(rig.right_centre - [130.0, 0, 0]) <= 1.2 + 1e-9
    assert rig_to_dict(rig)["T"] == rig.T.tolist()
    ideal = default_rig(0, distortion=(0, 0, 0, 0, 0), misalignment=False)
    assert np.all(ideal.left.dist == 0) and np.allclose(ideal.R, np.eye(3)) and np.allclose(ideal.T, [-130, 0, 0])
    assert not np.allclose(default_rig(1).R, rig.R)


def test_marker_description_default():
    m = MarkerDescription.default()
    assert m.outer_size == 40.0 and m.px_per_mm == pytest.approx(12.5)
    assert m.load_image().shape == (800, 800)
    assert np.allclose(m.reference_px, m.outer_corners_px.mean(axis=0))
    corners = m.outer_corners()
    assert np.allclose(corners[:, :2], [[-20, 20], [20, 20], [20, -20], [-20, -20]])
    assert np.allclose(m.png_from_plate(m.plate_from_png(m.outer_corners_px)), m.outer_corners_px)
    # The pattern has no rotational symmetry (so SIFT gives one orientation).
    img = m.load_image().astype(float)
    for k in (1, 2, 3):
        assert np.abs(np.rot90(img, k) - img).mean() > 10
    assert np.abs(img[:, ::-1] - img).mean() > 10
    again = MarkerDescription.from_dict(m.to_dict(), folder=m.folder)
    assert again.to_dict() == m.to_dict()


def test_marker_description_rejects_bad_files(tmp_path):
    from core.errors import RoboCalError
    good = MarkerDescription.default().to_dict()
    for key, value, field in (("outer_size", "40", "outer_size"), ("format", "robocal.marker/2", "format"),
                              ("outer_corners_px", [[0, 0]], "outer_corners_px"), ("plate_size", [10, 10], "plate_size")):
        bad = dict(good, **{key: value})
        with pytest.raises(RoboCalError) as info:
            MarkerDescription.from_dict(bad, source=tmp_path / "m.json")
        assert info.value.field == field


# -- the lab -------------------------------------------------------------------------------

@pytest.fixture(scope="module")
def lab(built_lab):
    return built_lab(seed=0)


def test_lab_robots(lab):
    nominal = lab.nominal_robot
    preset = read_robot(robot_path("educational_6r"))
    assert nominal.dh_arrays().keys() == preset.dh_arrays().keys()
    for k, v in preset.dh_arrays().items():
        assert np.allclose(nominal.dh_arrays()[k], v)
    # Base: z up (camera −y), in front of and below the cameras.
    assert np.allclose(nominal.base[:3, 2], [0, -1, 0])
    assert 600 < nominal.base[2, 3] < 900 and nominal.base[1, 3] > 100
    # The true base differs a little from the nominal one (it is identified anyway).
    d = tf.invert(nominal.base) @ lab.true_robot.base
    assert 2.0 <= np.linalg.norm(d[:3, 3]) <= 5.0 + 1e-9
    assert 0.2 <= np.rad2deg(tf.rotation_angle(d[:3, :3])) <= 0.5 + 1e-9
    # Round trip through the robot file format keeps the base in the camera frame.
    again = robot_from_dict(robot_to_dict(lab.true_robot))
    q = np.deg2rad([10, -20, 30, 40, -50, 60])
    assert np.allclose(again.target_position(q, "marker"), lab.marker_position(q), atol=1e-9)


def test_random_visible_poses(lab):
    rng = np.random.default_rng(4)
    Q = lab.random_visible_poses(25, rng)
    assert Q.shape == (25, 6)
    assert lab.true_robot.within_limits(Q).all()
    vis = lab.visibility(Q)
    assert vis.visible.all()
    depth = np.array([lab.marker_position(q)[2] for q in Q])
    assert depth.min() >= 400 and depth.max() <= 900
    # Joint values are whole thousandths of a degree, as a controller reports them.
    deg = np.rad2deg(Q)
    assert np.allclose(deg, np.round(deg, 3), atol=1e-9)
    assert len({tuple(q) for q in np.round(deg, 3)}) == 25
    assert np.array_equal(Q, lab.random_visible_poses(25, np.random.default_rng(4)))


def test_random_board_poses_are_visible_and_spread(lab):
    poses = lab.random_board_poses(12, np.random.default_rng(3))
    assert len(poses) == 12
    b = lab.board
    outline = np.array([[-2, -2, 0], [b.cols + 1, -2, 0], [b.cols + 1, b.rows + 1, 0], [-2, b.rows + 1, 0]]) * b.square
    depths, tilts = [], []
    for T in poses:
        assert np.allclose(T[:3, :3] @ T[:3, :3].T, np.eye(3))
        P = tf.transform_points(T, outline)
        assert lab.rig.left.in_image(lab.rig.left.project(P), BOARD_MARGIN_PX).all()
        assert lab.rig.right.in_image(lab.rig.right.project(lab.rig.to_right(P)), BOARD_MARGIN_PX).all()
        centre = tf.transform_points(T, np.array([[(b.cols - 1) * b.square / 2, (b.rows - 1) * b.square / 2, 0]]))[0]
        depths.append(centre[2])
        tilts.append(np.rad2deg(np.arccos(T[2, 2])))     # board z vs camera z
    assert BOARD_DEPTH[0] <= min(depths) and max(depths) <= BOARD_DEPTH[1]
    assert max(depths) - min(depths) > 250
    assert max(tilts) <= 40.0 + 1e-6 and max(tilts) > 20.0


@pytest.mark.parametrize("name", ["puma560", "ur5", "abb_irb120"])
def test_lab_works_with_bigger_presets(name):
    lab = VirtualLab.create(read_robot(robot_path(name)), seed=1)
    Q = lab.random_visible_poses(5, np.random.default_rng(0))
    assert lab.visibility(Q).visible.all()
    depth = np.array([lab.marker_position(q)[2] for q in Q])
    assert ((depth >= 400) & (depth <= 900)).all()
