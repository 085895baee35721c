"""Per-robot joint map: how a controller's joint values relate to the model's.

    controller = sign * (to_unit(q) + offset)        q: internal units (rad / mm)
    q          = from_unit(controller / sign - offset)

`units`: "deg" (revolute joints in degrees, prismatic in mm), "rad" (radians / mm) or
"ticks" (encoder counts: `ticks_per_unit` counts per degree for revolute joints, per mm for
prismatic ones). `offset` is in the controller's units before the sign (the controller's
value at the model's zero, signed as the model's joint); `sign` is +1 or -1 per joint.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from core.errors import RoboCalError

UNITS = ("deg", "rad", "ticks")


@dataclass
class JointMap:
    revolute: np.ndarray                       # bool per joint
    units: str = "deg"
    sign: np.ndarray | None = None             # +1 / -1 per joint (default +1)
    offset: np.ndarray | None = None           # controller units (default 0)
    ticks_per_unit: np.ndarray | None = None   # per joint, "ticks" only (counts per deg / mm)
    _scale: np.ndarray = field(init=False, repr=False)

    def __post_init__(self):
        n = len(self.revolute)
        self.revolute = np.asarray(self.revolute, dtype=bool)
        if self.units not in UNITS:
            raise RoboCalError(f"joint units '{self.units}' are not one of {', '.join(UNITS)}", field="units")
        self.sign = _per_joint(self.sign, 1.0, n, "sign")
        if not np.all(np.isin(self.sign, (-1.0, 1.0))):
            raise RoboCalError("every joint sign must be 1 or -1", field="sign")
        self.offset = _per_joint(self.offset, 0.0, n, "offset")
        if self.units == "ticks":
            if self.ticks_per_unit is None:
                raise RoboCalError("joint units 'ticks' need ticks_per_unit (counts per degree or mm)",
                                   field="ticks_per_unit")
            self.ticks_per_unit = _per_joint(self.ticks_per_unit, 1.0, n, "ticks_per_unit")
            if not np.all(self.ticks_per_unit > 0):
                raise RoboCalError("ticks_per_unit must be positive", field="ticks_per_unit")
        deg = np.where(self.revolute, 180.0 / np.pi, 1.0)           # internal -> deg / mm
        self._scale = {"deg": deg, "rad": np.ones(n),
                       "ticks": deg * (self.ticks_per_unit if self.ticks_per_unit is not None else 1.0)}[self.units]

    @classmethod
    def from_dict(cls, revolute, data: dict | None) -> "JointMap":
        data = data or {}
        return cls(revolute, units=data.get("units", "deg"), sign=data.get("sign"), offset=data.get("offset"),
                   ticks_per_unit=data.get("ticks_per_unit"))

    def to_controller(self, q) -> np.ndarray:
        """Internal joint values (rad / mm) -> the controller's values."""
        return self.sign * (np.asarray(q, dtype=float) * self._scale + self.offset)

    def from_controller(self, values) -> np.ndarray:
        """The controller's values -> internal joint values (rad / mm)."""
        return (np.asarray(values, dtype=float) / self.sign - self.offset) / self._scale


def _per_joint(value, default: float, n: int, name: str) -> np.ndarray:
    if value is None:
        return np.full(n, default)
    arr = np.asarray(value, dtype=float).reshape(-1)
    if arr.size == 1:
        return np.full(n, float(arr[0]))
    if arr.size != n:
        raise RoboCalError(f"expected {n} values (one per joint), got {arr.size}", field=name)
    return arr
