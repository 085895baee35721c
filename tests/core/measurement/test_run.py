"""The measurement run: per-pose writes, rejects with reasons, cancel, pause, resume, robot limits."""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from core import transforms as tf
from core.errors import RoboCalError
from core.measurement.run import (RejectsWriter, poses_from_internal, read_rejects, rejects_path_for,
                                  run_measurements)
from core.measurement.file import read_measurements
from core.poses.file import PoseList, write_poses, read_poses
from core.robot.simulated import SimulatedRobot

from tests.core import marker_scenes as scenes


def fake_locate(left, right):
    """Points from the joint values the fake capture passes through; q1 < 0 is 'not found'."""
    q = np.asarray(left, dtype=float)
    if q[0] < 0:
        return SimpleNamespace(ok=False, reason=f"left image: no marker found (q1 = {q[0]:.2f})")
    return SimpleNamespace(ok=True, reason="", point=10.0 * q[:3] + [0, 0, 600.0],
                           covariance=np.diag([1e-4, 2e-4, 4e-3]), sigma=np.sqrt([1e-4, 2e-4, 4e-3]))


def fake_capture(q):
    return np.asarray(q, dtype=float), np.asarray(q, dtype=float)


def pose_list(n=6, seed=0, negative=(2,)):
    rng = np.random.default_rng(seed)
    q = np.round(rng.uniform(5, 60, (n, 6)), 3)
    for i in negative:
        q[i, 0] = -q[i, 0]
    return PoseList(q_file=q, Q=np.deg2rad(q), pose=np.arange(10, 10 + n))


def test_each_point_is_on_disk_when_its_pose_is_done(tmp_path):
    out = tmp_path / "meas.csv"
    rejects = rejects_path_for(out)
    assert rejects.name == "meas.rejects.csv"
    seen = []

    def on_pose(outcome):
        if outcome.status == "measured":
            meas = read_measurements(out)
            assert int(meas.pose[-1]) == outcome.pose                  # already written and readable
            np.testing.assert_allclose(meas.xyz[-1], outcome.point, atol=1e-6)
        else:
            assert outcome.pose in read_rejects(rejects)
        seen.append(outcome.pose)

    poses = pose_list()
    result = run_measurements(poses, out, locate=fake_locate, capture=fake_capture, on_pose=on_pose)
    assert seen == list(range(10, 16))
    assert len(result.measured) == 5 and len(result.rejected) == 1 and not result.cancelled
    assert result.rejected[0].pose == 12 and "no marker found" in result.rejected[0].reason
    meas = read_measurements(out)
    assert list(meas.pose) == [10, 11, 13, 14, 15] and meas.target == ["marker"] * 5
    np.testing.assert_allclose(meas.q_file, poses.q_file[[0, 1, 3, 4, 5]], atol=1e-6)
    np.testing.assert_allclose(meas.sigma[0], np.sqrt([1e-4, 2e-4, 4e-3]), atol=1e-6)
    rej = read_rejects(rejects)
    assert list(rej) == [12] and rej[12][0] == "marker" and "no marker found" in rej[12][2]
    np.testing.assert_allclose(rej[12][1], poses.q_file[2], atol=1e-6)
    assert rejects.read_text().startswith("# robocal.rejects/1")
    s = result.summary()
    assert s["measured"] == 5 and s["rejected"] == 1 and s["rejects_list"][0]["pose"] == 12


def test_cancel_mid_run_then_resume_loses_nothing(tmp_path):
    out = tmp_path / "meas.csv"
    poses = pose_list(8)
    done = []
    result = run_measurements(poses, out, locate=fake_locate, capture=fake_capture,
                              on_pose=lambda o: done.append(o.pose), cancelled=lambda: len(done) >= 3)
    assert result.cancelled and len(result.outcomes) == 3 and result.remaining == 5
    assert list(read_measurements(out).pose) == [10, 11]              # pose 12 was rejected
    assert list(read_rejects(rejects_path_for(out))) == [12]
    before = read_measurements(out)
    progress = []
    again = run_measurements(poses, out, locate=fake_locate, capture=fake_capture,
                             progress=lambda f, m: progress.append(f))
    assert not again.cancelled
    assert len(again.skipped) == 3 and all("earlier run" in o.reason for o in again.skipped)
    meas = read_measurements(out)
    np.testing.assert_allclose(meas.xyz[:before.n_points], before.xyz)        # nothing lost or rewritten
    assert sorted(meas.pose) == [p for p in range(10, 18) if p != 12]           # each pose once
    assert list(read_rejects(rejects_path_for(out))) == [12]
    assert progress[-1] == 1.0
    # a third run has nothing left to do
    third = run_measurements(poses, out, locate=fake_locate, capture=fake_capture)
    assert len(third.skipped) == 8 and not third.measured and not third.rejected


def test_pause_waits_between_poses(tmp_path):
    calls = {"n": 0}

    def paused():
        calls["n"] += 1
        return calls["n"] <= 4           # paused at first, then released

    messages = []
    result = run_measurements(pose_list(2, negative=()), tmp_path / "m.csv", locate=fake_locate,
                              capture=fake_capture, paused=paused, pause_poll=0.001,
                              progress=lambda f, m: messages.append(m))
    assert len(result.measured) == 2 and "paused" in messages


def test_cancel_while_paused(tmp_path):
    result = run_measurements(pose_list(3, negative=()), tmp_path / "m.csv", locate=fake_locate,
                              capture=fake_capture, paused=lambda: True, cancelled=lambda: True, pause_poll=0.001)
    assert result.cancelled and not result.outcomes


def test_partly_written_last_line_is_redone(tmp_path):
    out = tmp_path / "meas.csv"
    poses = pose_list(4, negative=())
    run_measurements(poses, out, locate=fake_locate, capture=fake_capture, cancelled=lambda: False,
                     on_pose=lambda o: None)
    text = out.read_text().splitlines()
    out.write_text("\n".join(text[:-1]) + "\n" + text[-1][:15])        # the program died mid-write
    result = run_measurements(poses, out, locate=fake_locate, capture=fake_capture)
    assert [o.pose for o in result.measured] == [13]
    assert sorted(read_measurements(out).pose) == [10, 11, 12, 13]


def test_resume_refuses_another_pose_list_and_overwrite(tmp_path):
    out = tmp_path / "meas.csv"
    run_measurements(pose_list(3, negative=()), out, locate=fake_locate, capture=fake_capture)
    with pytest.raises(RoboCalError, match="other joint values"):
        run_measurements(pose_list(3, seed=1, negative=()), out, locate=fake_locate, capture=fake_capture)
    with pytest.raises(RoboCalError, match="already holds 3 measurements"):
        run_measurements(pose_list(3, negative=()), out, locate=fake_locate, capture=fake_capture, resume=False)
    dup = PoseList(q_file=np.zeros((2, 6)), Q=np.zeros((2, 6)), pose=np.array([1, 1]))
    with pytest.raises(RoboCalError, match="twice"):
        run_measurements(dup, tmp_path / "x.csv", locate=fake_locate, capture=fake_capture)


def test_retry_rejected(tmp_path):
    out = tmp_path / "meas.csv"
    poses = pose_list(3)
    run_measurements(poses, out, locate=fake_locate, capture=fake_capture)
    fixed = lambda left, right: fake_locate(np.abs(left), right)        # noqa: E731 (the marker is found now)
    again = run_measurements(poses, out, locate=fixed, capture=fake_capture, retry_rejected=True)
    assert [o.pose for o in again.measured] == [12]
    assert sorted(read_measurements(out).pose) == [10, 11, 12]


def test_capture_failure_and_foreign_rejects_file(tmp_path):
    def broken(q):
        raise RoboCalError("camera disconnected")

    result = run_measurements(pose_list(1, negative=()), tmp_path / "m.csv", locate=fake_locate, capture=broken)
    assert result.rejected[0].reason == "capture failed: camera disconnected"
    foreign = tmp_path / "f.rejects.csv"
    foreign.write_text("something else\n")
    with pytest.raises(RoboCalError, match="another run"):
        RejectsWriter(foreign, 6)


def test_driver_refuses_joints_outside_limits_and_stops_abort(tmp_path):
    robot_model = scenes.lab().true_robot
    lo, hi = robot_model.limits()
    Q = np.zeros((3, robot_model.dof))
    Q[1, 1] = hi[1] + 0.1                 # beyond joint 2's upper limit
    poses = poses_from_internal(Q, robot_model)
    robot = SimulatedRobot(robot_model)
    robot.connect()
    result = run_measurements(poses, tmp_path / "m.csv", locate=fake_locate, capture=fake_capture, driver=robot)
    assert [o.status for o in result.outcomes] == ["measured", "rejected", "measured"]
    assert "outside its limits" in result.rejected[0].reason and "not moved" in result.rejected[0].reason
    assert robot.move_count == 2
    robot.stop()
    with pytest.raises(RoboCalError, match="stopped"):
        run_measurements(poses, tmp_path / "n.csv", locate=fake_locate, capture=fake_capture, driver=robot)
    assert not (tmp_path / "n.csv").exists() or "marker" not in (tmp_path / "n.csv").read_text()


class EncoderRobot(SimulatedRobot):
    """Reaches every pose 0.01° off on joint 1, as real encoders report it."""

    def current_joints(self):
        q = super().current_joints().copy()
        q[0] += np.deg2rad(0.01)
        return q


def test_the_reported_joint_values_are_recorded_and_a_stop_during_capture_records_nothing(tmp_path):
    robot_model = scenes.lab().true_robot
    Q = np.deg2rad([[10.0, 20, 30, 0, 40, 0], [12.0, 22, 28, 5, 35, 10], [15.0, 18, 25, 0, 30, 0]])
    poses = poses_from_internal(Q, robot_model)
    with EncoderRobot(robot_model) as robot:
        run_measurements(poses, tmp_path / "m.csv", locate=fake_locate, capture=fake_capture, driver=robot)
    meas = read_measurements(tmp_path / "m.csv")
    np.testing.assert_allclose(meas.q_file[:, 0], poses.q_file[:, 0] + 0.01, atol=1e-6)
    np.testing.assert_allclose(meas.q_file[:, 1:], poses.q_file[:, 1:], atol=1e-6)

    with SimulatedRobot(robot_model) as robot:
        def capture_then_stop(q):
            robot.stop()                  # Esc pressed while the cameras were grabbing
            return fake_capture(q)

        with pytest.raises(RoboCalError, match="stopped while this pose was captured"):
            run_measurements(poses, tmp_path / "s.csv", locate=fake_locate, capture=capture_then_stop, driver=robot)
    assert "marker" not in (tmp_path / "s.csv").read_text()


def test_virtual_lab_run_with_the_real_pipeline(tmp_path):
    from core.stereo.rectification import StereoRectification
    from core.marker.location import MarkerLocator

    lab = scenes.lab()
    robot_model = lab.true_robot
    Q = lab.random_visible_poses(2, np.random.default_rng(4))
    # a configuration inside the limits where the marker is not in view of both cameras
    rng = np.random.default_rng(9)
    lo, hi = robot_model.limits()
    while True:
        q = rng.uniform(np.maximum(lo, -np.pi), np.minimum(hi, np.pi))
        if not lab.visibility(q[None]).visible[0]:
            break
    Q = np.vstack([Q[:1], q[None], Q[1:]])
    poses = poses_from_internal(Q, robot_model)
    write_poses(tmp_path / "poses.csv", poses.q_file)
    poses = read_poses(tmp_path / "poses.csv", robot_model)         # as the Measurement step reads them
    locator = MarkerLocator(scenes.trained(), StereoRectification.from_rig(lab.rig))
    render_rng = np.random.default_rng(1)
    with SimulatedRobot(robot_model) as robot:
        result = run_measurements(poses, tmp_path / "meas.csv", locate=locator.locate, driver=robot,
                                  capture=lambda qq: lab.render_marker_pair(qq, render_rng))
    assert [o.status for o in result.outcomes] == ["measured", "rejected", "measured"]
    assert result.rejected[0].reason and result.rejected[0].location is not None
    meas = read_measurements(tmp_path / "meas.csv", robot_model)
    for k, i in enumerate((0, 2)):
        truth = lab.marker_position(poses.Q[i])
        assert np.linalg.norm(meas.xyz[k] - truth) < 0.15
        assert np.all(meas.sigma[k] < 0.05)
    assert result.measured[0].location.left.ok            # what the GUI draws is kept


def test_an_unusable_rejects_path_is_a_clear_error(tmp_path):
    (tmp_path / "m.rejects.csv").mkdir()              # a folder where the rejects file should be
    with pytest.raises(RoboCalError, match="m.rejects.csv"):
        RejectsWriter(tmp_path / "m.rejects.csv", 6)


def test_the_run_records_the_marker_orientation_when_located(tmp_path):
    from core.marker.orientation import MarkerOrientation

    def locate(left, right):
        loc = fake_locate(left, right)
        q = np.asarray(left, dtype=float)        # joint values in rad (fake_capture)
        if loc.ok and q[1] > np.deg2rad(30):     # some points come without an orientation
            R = tf.rot_vec(q[:3] / 10.0)
            loc.orientation = MarkerOrientation(R, np.diag(np.deg2rad([0.01, 0.02, 0.03]) ** 2), loc.point)
        return loc

    out = tmp_path / "meas.csv"
    poses = pose_list()
    run_measurements(poses, out, locate=locate, capture=fake_capture)
    meas = read_measurements(out)
    assert out.read_text().startswith("# robocal.measurements/1.1")
    expect = poses.q_file[[0, 1, 3, 4, 5], 1] > 30
    assert list(meas.has_orientation) == list(expect) and expect.any() and not expect.all()
    for i in np.flatnonzero(expect):
        np.testing.assert_allclose(meas.rotation[i], np.deg2rad(meas.q_file[i, :3]) / 10.0, atol=1e-7)
        np.testing.assert_allclose(np.rad2deg(meas.rotation_sigma[i]), [0.01, 0.02, 0.03], atol=1e-6)
