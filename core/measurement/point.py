"""A measured point that carries its own covariance.

An instrument that knows how precisely it measured each point (the marker locator through its
edges and the stereo geometry; a laser tracker's file with σ columns) returns a MeasuredPoint:
the position (3,) in mm in the measurement frame, usable wherever a plain array is, with
`covariance` (3, 3) in mm² in the same frame. Arrays computed from it (a copy, a slice, the
result of arithmetic) carry no covariance (None), and np.asarray / np.array of it are plain
arrays. A covariance that is not one (not finite, not symmetric, a negative variance or none at
all) is dropped: the point then counts as measured with the calibration's own noise.
"""
from __future__ import annotations

import numpy as np


class MeasuredPoint(np.ndarray):
    """A point (3,) mm with its covariance (3, 3) mm² (None when the instrument did not give one)."""

    covariance: np.ndarray | None

    def __new__(cls, xyz, covariance=None):
        obj = np.asarray(xyz, dtype=float).reshape(3).copy().view(cls)
        obj.covariance = usable_covariance(covariance)
        return obj

    def __array_finalize__(self, obj):
        self.covariance = None          # a slice or a result of arithmetic is no longer the measured point

    def __reduce__(self):
        return MeasuredPoint, (np.asarray(self).copy(), self.covariance)


def usable_covariance(covariance) -> np.ndarray | None:
    """`covariance` as a (3, 3) float array when it is a covariance (finite, symmetric, positive
    semi-definite with a positive trace, to rounding), else None."""
    if covariance is None:
        return None
    C = np.asarray(covariance, dtype=float)
    if C.shape != (3, 3) or not np.all(np.isfinite(C)):
        return None
    trace = float(np.trace(C))
    if trace <= 0.0 or not np.allclose(C, C.T, rtol=1e-6, atol=1e-12 * trace) \
            or np.linalg.eigvalsh(0.5 * (C + C.T)).min() < -1e-6 * trace:
        return None
    return 0.5 * (C + C.T)


def point_covariance(point) -> np.ndarray | None:
    """The covariance (3, 3) mm² a measured point carries, or None."""
    return point.covariance if isinstance(point, MeasuredPoint) else None


def located_point(location) -> MeasuredPoint | None:
    """A marker location's (core.marker.location.MarkerLocation) point with its covariance, None
    when the marker was not found."""
    if not location.ok:
        return None
    return MeasuredPoint(location.point, location.covariance)
