import os
import pickle
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from core.errors import RoboCalError
from core.monitoring.check import check_limits, run_check
from core.monitoring.log import read_check_log
from core.monitoring.uncertainty import calibration_uncertainty
from core.virtual_lab.ideal_measurements import ideal_measure
from tests.core.monitoring.cell import SIGMA, calibrate, cell

ROOT = Path(__file__).resolve().parents[3]


def test_check_logs_every_point_and_closes_with_the_overall_row(tmp_path):
    c = cell()
    log = tmp_path / "checks.csv"
    first = run_check(c.model, c.unc, c.Q, ideal_measure(c.lab, sigma_mm=SIGMA, seed=1), log=log)
    second = run_check(c.model, c.unc, c.Q, ideal_measure(c.lab, sigma_mm=SIGMA, seed=2), log=log)
    assert first.within and second.within
    logged = read_check_log(log)
    assert len(logged.checks) in (1, 2)         # two runs in the same second share a name
    points = [p for ch in logged.checks for p in ch.points]
    assert len(points) == 16
    assert points[3].error_mm == pytest.approx(first.points[3].error_mm, abs=1e-4)
    np.testing.assert_allclose(points[3].measured, first.points[3].measured, atol=1e-4)
    assert logged.checks[-1].rms_mm == pytest.approx(second.rms_mm, abs=1e-4)
    # a no-change error is of the order of the noise; the limit a few σ
    assert 0.5 * SIGMA * np.sqrt(3) < first.rms_mm < 2 * SIGMA * np.sqrt(3)
    assert 1.5 * first.rms_mm < first.rms_limit_mm < 6 * SIGMA


def test_missing_marker_is_reported_not_judged(tmp_path):
    c = cell()
    ideal = ideal_measure(c.lab, sigma_mm=SIGMA, seed=1)
    calls = []

    def measure(q):
        calls.append(1)
        return None if len(calls) == 2 else ideal(q)
    result = run_check(c.model, c.unc, c.Q, measure)
    assert [p for p, _ in result.missing] == [1] and len(result.points) == 7


def test_cancel_keeps_the_points_measured(tmp_path):
    c = cell()
    ideal = ideal_measure(c.lab, sigma_mm=SIGMA, seed=1)
    done = []

    def measure(q):
        done.append(1)
        return ideal(q)
    result = run_check(c.model, c.unc, c.Q, measure, log=tmp_path / "c.csv", cancelled=lambda: len(done) >= 3)
    assert result.cancelled and not result.within and len(result.points) == 3
    logged = read_check_log(tmp_path / "c.csv")
    assert len(logged.checks[0].points) == 3 and not logged.checks[0].finished


KILL_SCRIPT = """
import os, pickle, signal, sys
sys.path.insert(0, {root!r})
from core.monitoring.check import run_check
from core.virtual_lab.ideal_measurements import ideal_measure
with open({cell!r}, "rb") as fh:
    c = pickle.load(fh)
ideal = ideal_measure(c.lab, sigma_mm={sigma!r}, seed=1)
n = []
def measure(q):
    n.append(1)
    if len(n) == 5:
        os.kill(os.getpid(), signal.SIGKILL)
    return ideal(q)
run_check(c.model, c.unc, c.Q, measure, log={log!r})
"""


def test_killed_check_loses_nothing_it_measured(tmp_path):
    log = tmp_path / "checks.csv"
    # the child checks the shared cell as this process has it (pickled), instead of calibrating it again
    shared = tmp_path / "cell.pickle"
    shared.write_bytes(pickle.dumps(cell()))
    script = KILL_SCRIPT.format(root=str(ROOT), log=str(log), cell=str(shared), sigma=SIGMA)
    proc = subprocess.run([sys.executable, "-c", script],
                          env={**os.environ, "PYTHONPATH": str(ROOT)}, capture_output=True, timeout=120)
    assert proc.returncode == -9, proc.stderr.decode()[-500:]
    logged = read_check_log(log)
    assert len(logged.checks[0].points) == 4 and not logged.checks[0].finished
    # appending again works after the kill
    c = cell()
    run_check(c.model, c.unc, c.Q, ideal_measure(c.lab, sigma_mm=SIGMA, seed=3), log=log)
    assert sum(len(ch.points) for ch in read_check_log(log).checks) == 12


def test_false_alarm_rate_is_near_the_nominal_one():
    """No change: over 15 calibrations × 40 checks at α = 5 %, the alarm rate is 5 % ± 2.2 %
    (3 binomial σ for 600 checks); the per-pose and overall limits are split by Bonferroni, so
    the rate may fall below α but not far above."""
    c = cell()
    alarms = total = 0
    for seed in range(15):
        model = calibrate(c.lab, 100 + seed)
        unc = calibration_uncertainty(model)
        limits = check_limits(model, unc, c.Q, ["marker"] * len(c.Q), 0.05)
        for k in range(40):
            r = run_check(model, unc, c.Q, ideal_measure(c.lab, sigma_mm=SIGMA, seed=1000 * seed + k), alpha=0.05,
                          limits=limits)
            alarms += not r.within
            total += 1
    rate = alarms / total
    assert 0.02 <= rate <= 0.072, rate


def test_wrong_poses_refused():
    c = cell()
    with pytest.raises(RoboCalError, match="joint values"):
        run_check(c.model, c.unc, c.Q[:, :5], ideal_measure(c.lab))


def test_a_point_measured_less_precisely_is_judged_by_its_own_covariance(tmp_path):
    """Pose 3 measured with 2.4 × the calibration's σ per axis (as the cameras measure a marker
    far off), twice its own 3D σ away: within the limit its own covariance gives, out of the one
    σ gives. A point measured better than σ keeps σ's limit. Every limit is logged."""
    from core.kinematics.jacobian import predict_points
    from core.measurement.point import MeasuredPoint
    c = cell()
    predicted = predict_points(c.model, c.Q, ["marker"] * len(c.Q))
    wide = (2.4 * c.unc.sigma_mm) ** 2 * np.eye(3)
    error = np.array([1.0, -1.0, 1.0]) / np.sqrt(3) * 2.0 * 2.4 * c.unc.sigma_mm * np.sqrt(3)

    def measure(own):
        points = iter(range(len(c.Q)))

        def at(q):
            k = next(points)
            if k == 3:
                return MeasuredPoint(predicted[k] + error, own)
            return MeasuredPoint(predicted[k], (0.5 * c.unc.sigma_mm) ** 2 * np.eye(3))
        return at
    limits = check_limits(c.model, c.unc, c.Q, ["marker"] * len(c.Q))
    own = run_check(c.model, c.unc, c.Q, measure(wide), limits=limits, log=tmp_path / "c.csv")
    plain = run_check(c.model, c.unc, c.Q, measure(None), limits=limits)
    assert own.points[3].within and not plain.points[3].within
    assert plain.points[3].limit_mm == pytest.approx(limits.per_point[3], rel=1e-12)
    # the parameter part is small against the noise: the limit grows about as the point's σ
    assert 2.2 < own.points[3].limit_mm / limits.per_point[3] < 2.4
    for k in (0, 1, 2, 4):
        assert own.points[k].limit_mm == pytest.approx(limits.per_point[k], rel=1e-9)
    assert own.rms_limit_mm > plain.rms_limit_mm
    np.testing.assert_allclose(own.points[3].covariance, wide)
    logged = read_check_log(tmp_path / "c.csv").checks[-1]
    assert [p.limit_mm for p in logged.points] == pytest.approx([p.limit_mm for p in own.points], abs=1e-4)
    assert logged.rms_limit_mm == pytest.approx(own.rms_limit_mm, abs=1e-4)


def test_a_missing_pose_leaves_the_others_judged_by_their_own_covariance():
    """Pose 2 not measured: each other point keeps its own limit, and the overall limit is that of
    the seven measured with their covariances (the parameter part of the poses measured only)."""
    from core.kinematics.jacobian import predict_points
    from core.measurement.point import MeasuredPoint
    from core.monitoring.uncertainty import norm_limit, prediction_covariance
    c = cell()
    predicted = predict_points(c.model, c.Q, ["marker"] * len(c.Q))
    own = [np.diag([1.0, 1.0, 9.0]) * (k + 1) * c.unc.sigma_mm ** 2 for k in range(len(c.Q))]
    points = iter(range(len(c.Q)))

    def measure(q):
        k = next(points)
        return None if k == 2 else MeasuredPoint(predicted[k], own[k])
    result = run_check(c.model, c.unc, c.Q, measure)
    keep = [k for k in range(len(c.Q)) if k != 2]
    assert [p.pose for p in result.points] == keep and result.missing[0][0] == 2
    S = prediction_covariance(c.model, c.unc, c.Q[keep], ["marker"] * len(keep), [own[k] for k in keep])
    assert result.rms_limit_mm == pytest.approx(norm_limit(S, 1 - 0.01 / 2) / np.sqrt(len(keep)), rel=1e-9)
    n = len(c.Q)
    for p, k in zip(result.points, keep):
        block = S[3 * keep.index(k):3 * keep.index(k) + 3, 3 * keep.index(k):3 * keep.index(k) + 3]
        assert p.limit_mm == pytest.approx(norm_limit(block, 1 - 0.01 / (2 * n)), rel=1e-9)
