import pickle

import numpy as np

from core.measurement.point import MeasuredPoint, located_point, point_covariance


def test_a_measured_point_is_an_array_that_carries_its_covariance():
    cov = np.diag([1e-4, 2e-4, 9e-4])
    p = MeasuredPoint([1.0, 2.0, 3.0], cov)
    np.testing.assert_array_equal(p, [1.0, 2.0, 3.0])
    np.testing.assert_array_equal(point_covariance(p), cov)
    # what is computed from it is no longer the measured point
    assert point_covariance(p - 1.0) is None and point_covariance(p[:2]) is None
    assert type(np.array([p, p])) is np.ndarray and type(np.asarray(p, dtype=float)) is np.ndarray
    assert point_covariance(np.array([1.0, 2.0, 3.0])) is None
    back = pickle.loads(pickle.dumps(p))        # e.g. passed to a worker process
    np.testing.assert_array_equal(point_covariance(back), cov)
    assert point_covariance(MeasuredPoint(p)) is None


def test_a_marker_location_gives_its_point_and_covariance():
    from core.marker.location import MarkerLocation
    loc = MarkerLocation(ok=True, point=np.array([10.0, 0.0, 800.0]), covariance=np.eye(3) * 4e-6)
    p = located_point(loc)
    np.testing.assert_array_equal(p, [10.0, 0.0, 800.0])
    np.testing.assert_array_equal(point_covariance(p), np.eye(3) * 4e-6)
    assert located_point(MarkerLocation(ok=False)) is None


def test_a_matrix_that_is_no_covariance_is_dropped():
    for bad in (np.full((3, 3), np.nan), np.zeros((3, 3)), np.diag([1e-4, -1e-4, 1e-4]), np.ones((2, 2)),
                np.array([[1e-4, 2e-4, 0], [2e-4, 1e-4, 0], [0, 0, 1e-4]])):
        assert point_covariance(MeasuredPoint([1.0, 2.0, 3.0], bad)) is None
