"""Pose selection: candidates, indices, greedy + exchange, ordering, poses.csv, bad input."""
from __future__ import annotations

import copy
import json

import numpy as np
import pytest

from core.errors import Cancelled, RoboCalError, UsageError
from core.kinematics.identifiability import analyse, characteristic_scales, observability_indices, observation_matrix
from core.robot.model import robot_path
from core.poses.candidates import (REJECT_COLLISION, REJECT_FACING, REJECT_FLOOR, REJECT_IMAGE, arm_polyline,
                                  generate_candidates, segment_distance, self_collision)
from core.poses.file import format_poses, read_poses, write_poses
from core.poses.ordering import distance_matrix, order_poses, path_length
from core.poses.selection import (INDEX_KEYS, INDEXES, _score, _Selector, indices_from_eigenvalues,
                                 minimum_poses, scaled_blocks, select_poses, write_selection)
from core.robot.file import read_robot, robot_from_dict, robot_to_dict, write_robot
from core.virtual_lab.lab import lab_options


@pytest.fixture(scope="module")
def arm():
    return read_robot(robot_path("educational_6r"))


@pytest.fixture(scope="module")
def blocks(arm):
    cands = generate_candidates(arm, 300, seed=3)
    A, names, scales, ident = scaled_blocks(arm, cands.Q, ["marker"])
    return cands, A, names, scales, ident


@pytest.fixture(scope="module")
def selection(arm):
    return select_poses(arm, 14, candidates=300, index="cond", seed=1, random_trials=40)


@pytest.fixture(scope="module")
def lab(built_lab):
    return built_lab(seed=0)


# -- indices ---------------------------------------------------------------------------------
def test_indices_equal_a_from_scratch_svd(arm, blocks):
    cands, A, names, scales, ident = blocks
    rng = np.random.default_rng(0)
    for n in (9, 15, 40):
        idx = rng.choice(len(cands), n, replace=False)
        phi, _ = observation_matrix(arm, cands.Q[idx], ["marker"], ident=ident)
        ref = observability_indices(phi, n_points=n, scales=characteristic_scales(arm, ident.free)).as_dict()
        M = np.einsum("nki,nkj->ij", A[idx], A[idx])
        fast = indices_from_eigenvalues(np.linalg.eigvalsh(M), n)
        for k in INDEXES:
            assert fast[k] == pytest.approx(ref[INDEX_KEYS[k]], rel=1e-7), k


def test_result_indices_are_those_of_the_written_poses(arm, selection, tmp_path):
    path = write_selection(selection, tmp_path / "poses.csv")
    poses = read_poses(path, arm)
    np.testing.assert_allclose(poses.Q, selection.Q, atol=1e-9)    # rounded to 0.001° before selection
    ident = analyse(arm, ["marker"])
    phi, names = observation_matrix(arm, poses.Q, ["marker"], ident=ident)
    assert names == selection.parameters
    ref = observability_indices(phi, n_points=len(poses), scales=characteristic_scales(arm, ident.free))
    assert ref.condition_number == pytest.approx(selection.value("cond"), rel=1e-9)
    assert ref.rank == len(names)
    # the curve passes through the selection
    k = list(selection.curve.n).index(14)
    assert selection.curve.selected["cond"][k] == pytest.approx(selection.value("cond"), rel=1e-6)


@pytest.mark.parametrize("index", INDEXES)
def test_fast_updates_agree_with_brute_force(blocks, index):
    """Determinant lemma / Woodbury / branch and bound pick what a full evaluation picks."""
    cands, A, *_ = blocks
    sel = _Selector(A, index)
    chosen = sel.greedy(12)
    info = sel.info(chosen)
    rest = np.setdiff1d(np.arange(len(A)), chosen)
    brute = _score(index, np.linalg.eigvalsh(info[None] + sel.G[rest]))
    assert sel.best_add(chosen) == rest[int(np.argmax(brute))]
    removal = _score(index, np.linalg.eigvalsh(info[None] - sel.G[chosen]))
    assert sel.best_remove(chosen) == int(np.argmax(removal))
    if index in ("O1", "O5"):
        closed = sel._closed_form_add(index, info, rest)
        exact_logdet = np.linalg.slogdet(info[None] + sel.G[rest])[1] - np.linalg.slogdet(info)[1]
        exact_trace = np.trace(np.linalg.inv(info)) - np.trace(np.linalg.inv(info[None] + sel.G[rest]), axis1=1, axis2=2)
        np.testing.assert_allclose(closed, exact_logdet if index == "O1" else exact_trace, rtol=1e-5)


# -- selection -------------------------------------------------------------------------------
def test_greedy_and_exchange_beat_random(selection):
    r = selection
    assert len(r.Q) == 14 and len(set(r.candidate_index.tolist())) == 14
    assert r.value("cond") < 0.75 * r.random_median("cond")
    assert r.ratio() == pytest.approx(r.value("cond") / r.random.median["cond"])
    # better than every one of the random selections
    assert r.value("cond") < np.min(r.random.values["cond"])
    assert r.indices.rank == len(r.parameters) == 25
    assert r.n_min == 9 and r.curve.n[0] == 9 and r.curve.n[-1] >= 24
    assert r.curve.selected["cond"][0] > r.curve.selected["cond"][-1]      # more poses help
    assert np.all(r.curve.selected["cond"] < r.curve.random_median["cond"])


@pytest.mark.parametrize("index", ["O1", "O3", "O4", "O5"])
def test_other_indices_beat_random(arm, index):
    r = select_poses(arm, 12, candidates=200, index=index, seed=2, random_trials=30, curve_max=12)
    assert r.value(index) > r.random_median(index)


def test_deterministic(arm, selection):
    again = select_poses(arm, 14, candidates=300, index="cond", seed=1, random_trials=40)
    np.testing.assert_array_equal(again.Q, selection.Q)
    np.testing.assert_array_equal(again.random.values["cond"], selection.random.values["cond"])
    other = select_poses(arm, 14, candidates=300, index="cond", seed=2, random_trials=40, curve_max=14)
    assert not np.array_equal(other.Q, selection.Q)


def test_ordering_shortens_travel(selection):
    r = selection
    assert r.travel_after < r.travel_before
    assert r.travel_after == pytest.approx(path_length(r.q_file, r.home_file))


def test_order_poses_is_a_permutation_and_two_opt_optimal():
    rng = np.random.default_rng(5)
    P = rng.uniform(-150, 150, (25, 6))
    start = np.zeros(6)
    for metric in ("max", "euclidean"):
        order = order_poses(P, start, metric)
        assert sorted(order.tolist()) == list(range(25))
        assert path_length(P[order], start, metric) < path_length(P, start, metric)
        # no 2-opt move improves the result
        nodes = np.vstack([start, P[order]])
        D = distance_matrix(nodes, metric)
        for i in range(1, 25):
            for j in range(i + 1, 26):
                before = D[i - 1, i] + (D[j, j + 1] if j + 1 < 26 else 0.0)
                after = D[i - 1, j] + (D[i, j + 1] if j + 1 < 26 else 0.0)
                assert after >= before - 1e-9
    assert distance_matrix(np.array([[0, 0], [3, -4]]), "max")[0, 1] == 4
    assert distance_matrix(np.array([[0, 0], [3, -4]]), "euclidean")[0, 1] == 5


def test_cancel(arm):
    with pytest.raises(Cancelled):
        select_poses(arm, 12, candidates=200, cancelled=lambda: True)
    calls = []
    select_poses(arm, 10, candidates=100, random_trials=10, curve_max=10,
                 progress=lambda f, m="": calls.append(f))
    assert calls and calls[-1] == 1.0 and all(0.0 <= f <= 1.0 for f in calls)


# -- candidates ------------------------------------------------------------------------------
def test_candidates_respect_margins_and_are_rounded(arm):
    c = generate_candidates(arm, 500, seed=0, margin=10.0)
    lo, hi = arm.limits()
    assert len(c) == 500 and c.drawn == 500 and c.n_rejected == 0
    assert np.all(c.Q >= lo + np.deg2rad(10) - 1e-9) and np.all(c.Q <= hi - np.deg2rad(10) + 1e-9)
    qf = arm.q_to_file(c.Q)
    np.testing.assert_allclose(qf, np.round(qf, 3), atol=1e-9)
    with pytest.raises(RoboCalError, match="leaves no range for joint 2"):
        arm.sampling_range(100.0)


def test_visibility_rejections(lab):
    opts = lab_options(lab)
    robot = opts.pop("robot")
    c = generate_candidates(robot, 150, seed=4, **opts)
    assert len(c) == 150
    assert c.drawn == len(c) + c.n_rejected
    assert c.rejected[REJECT_IMAGE] > 0 and c.rejected[REJECT_FACING] > 0 and c.rejected[REJECT_FLOOR] > 0
    from core.poses.visibility import marker_visibility
    v = marker_visibility(c.Q, robot, lab.rig, lab.plate_size, **opts["visibility"].as_kwargs())
    assert v.visible.all()
    np.testing.assert_allclose(c.depth, v.depth)
    r = select_poses(robot, 12, candidate_set=c, random_trials=20, curve_max=12, **opts)
    assert r.depth is not None and np.all((r.depth >= 400) & (r.depth <= 900))
    assert lab.visibility(r.Q).visible.mean() > 0.7       # the true robot mostly agrees


def test_no_visible_candidate_is_a_clear_error(lab):
    opts = lab_options(lab)
    robot = opts.pop("robot").copy()
    # limits around a configuration where the marker looks away from the cameras
    q0 = np.deg2rad([180.0, 0, 0, 0, 0, 0])
    for j, q in zip(robot.joints, q0):
        j.min, j.max = q - np.deg2rad(3.0), q + np.deg2rad(3.0)
    with pytest.raises(RoboCalError) as info:
        select_poses(robot, 12, candidates=50, margin=0.0, **opts)
    msg = info.value.message
    assert "no candidate pose puts the marker in view of both cameras" in msg
    assert "base pose in robot.json" in msg and "margins" in msg and "\n" not in msg


def test_too_few_poses_says_the_minimum(arm):
    with pytest.raises(UsageError) as info:
        select_poses(arm, 6, candidates=100)
    assert "at least 9 poses" in info.value.message and "25 identifiable parameters" in info.value.message
    with pytest.raises(UsageError, match="unknown observability index"):
        select_poses(arm, 12, index="O2")


def test_minimum_poses_of_a_robot(arm):
    # 25 identifiable parameters with the marker: 9 poses give 27 equations, 8 only 24
    assert minimum_poses(arm) == 9 and minimum_poses(arm, fixed=["J2.a"]) == 9          # 24 parameters
    assert minimum_poses(arm, fixed=["J2.a", "J3.a"]) == 8                               # 23 parameters
    assert minimum_poses(arm, ("probe",)) == 9                  # a target it lacks: its first one
    bare = copy.copy(arm)
    bare.targets = {}
    assert minimum_poses(bare) == 0


def test_more_poses_than_candidates(arm):
    with pytest.raises(RoboCalError, match="only 20 feasible candidate poses for 30 poses"):
        select_poses(arm, 30, candidates=20)


# -- self-collision --------------------------------------------------------------------------
def test_segment_distance_matches_sampling():
    rng = np.random.default_rng(1)
    P = rng.normal(size=(100, 4, 3)) * 50
    P[:10, 1] = P[:10, 0]                           # degenerate segments (points)
    P[10:20, 3] = P[10:20, 2] + 2 * (P[10:20, 1] - P[10:20, 0])   # parallel segments
    d = segment_distance(P[:, 0], P[:, 1], P[:, 2], P[:, 3])
    t = np.linspace(0, 1, 151)
    a = P[:, None, 0] + t[None, :, None] * (P[:, 1] - P[:, 0])[:, None]
    b = P[:, None, 2] + t[None, :, None] * (P[:, 3] - P[:, 2])[:, None]
    brute = np.linalg.norm(a[:, :, None] - b[:, None, :], axis=-1).min(axis=(1, 2))
    assert np.all(d <= brute + 1e-9) and np.all(brute - d < 1.5)


def test_capsule_self_collision(arm, tmp_path):
    robot = arm.copy()
    robot.collision_radius = np.array([30.0, 20.0, 20.0, 15.0, 15.0, 10.0])
    pts, links = arm_polyline(robot, np.zeros((1, 6)))
    assert pts.shape == (1, 15, 3) and links.tolist() == [0, 0, 1, 1, 2, 2, 3, 3, 4, 4, 5, 5, 6, 6]
    np.testing.assert_allclose(pts[0, -1], robot.target_position(np.zeros(6), "marker"))
    straight = np.zeros((1, 6))
    folded = np.deg2rad([[0.0, -60.0, -100.0, 0.0, 0.0, 0.0]])       # forearm folded through the column
    assert not self_collision(robot, straight)[0]
    assert self_collision(robot, folded)[0]
    assert not self_collision(arm, folded)[0]                        # no radii: no check
    c = generate_candidates(robot, 200, seed=0)
    assert c.rejected[REJECT_COLLISION] > 0 and not self_collision(robot, c.Q).any()
    # the robot file keeps the radii
    write_robot(robot, tmp_path / "r.json")
    again = read_robot(tmp_path / "r.json")
    np.testing.assert_allclose(again.collision_radius, robot.collision_radius)
    assert "collision" not in robot_to_dict(arm)
    data = robot_to_dict(robot)
    data["collision"] = {"radius": [1, 2]}
    with pytest.raises(RoboCalError, match="collision.radius"):
        robot_from_dict(data)


# -- poses.csv -------------------------------------------------------------------------------
def test_poses_file_round_trip_and_errors(arm, tmp_path):
    q = np.array([[1.5, -2, 3, 0, 45.25, -90], [0, 0, 0, 0, 0, 0]])
    path = write_poses(tmp_path / "poses.csv", q)
    assert path.read_text().splitlines()[:2] == ["pose,q1,q2,q3,q4,q5,q6", "0,1.500,-2.000,3.000,0.000,45.250,-90.000"]
    p = read_poses(path, arm)
    np.testing.assert_allclose(p.q_file, q)
    np.testing.assert_allclose(p.Q, np.deg2rad(q))
    assert p.pose.tolist() == [0, 1]
    bad = tmp_path / "bad.csv"
    bad.write_text(format_poses(q).replace("45.250", "abc"))
    with pytest.raises(RoboCalError, match="line 2, column 'q5': expected a number"):
        read_poses(bad)
    bad.write_text(format_poses(q[:, :5]))
    with pytest.raises(RoboCalError, match="5 joint columns but the robot"):
        read_poses(bad, arm)
    bad.write_text(format_poses(np.array([[0, 0, 0, 0, 0, 175.0]])))
    with pytest.raises(RoboCalError, match="outside the joint limits"):
        read_poses(bad, arm)


def test_result_as_json(selection):
    d = json.loads(json.dumps(selection.as_dict()))
    assert d["count"] == 14 and d["index"] == "cond" and len(d["poses"]) == 14
    assert d["indices"]["condition_number"] == pytest.approx(selection.value("cond"))
    assert d["random_median"]["condition_number"] == pytest.approx(selection.random_median("cond"))
    assert d["min_poses"] == 9 and d["travel_after"] < d["travel_before"]


def test_index_descriptions_match_the_definitions():
    from core.poses.selection import INDEX_DESCRIPTIONS, INDEXES, indices_from_eigenvalues

    assert list(INDEX_DESCRIPTIONS) == list(INDEXES)
    rng = np.random.default_rng(0)
    A = rng.normal(size=(60, 6))
    M = A.T @ A
    one = indices_from_eigenvalues(np.linalg.eigvalsh(M), 20)
    two = indices_from_eigenvalues(np.linalg.eigvalsh(4.0 * M), 20)    # every σ doubled: ellipsoid 2⁶ times smaller
    assert float(two["O1"]) == pytest.approx(2.0 * float(one["O1"]))    # O1 grows as the ellipsoid shrinks
    assert float(one["O5"]) == pytest.approx(1.0 / np.trace(np.linalg.inv(M)))   # 1 / total variance
