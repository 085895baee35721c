"""The accuracy map file (`robocal.accuracy_map/1`, JSON, `accuracy_map.json` in the project):
the map the Compensation step measured, for the report. docs/file-formats.md.

Per target: the target and the landings with the nominal and the calibrated model (mm,
measurement frame; null when not measured), their joints (deg / mm; null when unreachable) and
why a target was not measured. With it the robot base in the measurement frame (4x4, mm), where
the landings were measured, the calibrated robot file and the summary figures.
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from core.compensation.accuracy_map import AccuracyMap
from core.errors import RoboCalError
from core.robot.model import RobotModel
from core.files import atomic_write_json, read_json
from core.validate import check_format, require, text

FORMAT = "robocal.accuracy_map"
MAJOR = 1
NAME = "accuracy_map.json"


def _row(values) -> list | None:
    values = np.asarray(values, dtype=float)
    return None if not np.all(np.isfinite(values)) else [float(v) for v in values]


def _finite_or_none(value: float) -> float | None:
    return float(value) if np.isfinite(value) else None


def accuracy_map_dict(amap: AccuracyMap, robot: RobotModel | None = None) -> dict:
    """The `robocal.accuracy_map/1` object; joints in file units through `robot` (deg / mm;
    None: all revolute, deg)."""
    q_to_file = robot.q_to_file if robot is not None else np.rad2deg
    points = []
    for i in range(amap.n):
        points.append({"target_mm": _row(amap.targets[i]), "nominal_mm": _row(amap.before[i]),
                       "calibrated_mm": _row(amap.after[i]),
                       "q_nominal": _row(q_to_file(amap.q_before[i])), "q_calibrated": _row(q_to_file(amap.q_after[i])),
                       "note": amap.notes[i] if i < len(amap.notes) else ""})
    return {"format": f"{FORMAT}/{MAJOR}", "frame": "measurement frame (left camera), mm",
            "measured_by": amap.measured_by, "robot": amap.robot, "cancelled": amap.cancelled,
            "base": [[float(v) for v in row] for row in amap.base],
            "summary": {"n_targets": amap.n, "n_measured": int(amap.both.sum()),
                        "rms_nominal_mm": _finite_or_none(amap.rms_before_mm),
                        "rms_calibrated_mm": _finite_or_none(amap.rms_after_mm),
                        "max_nominal_mm": _finite_or_none(amap.max_before_mm),
                        "max_calibrated_mm": _finite_or_none(amap.max_after_mm),
                        "improvement": _finite_or_none(amap.improvement)},
            "points": points}


def write_accuracy_map(path: str | Path, amap: AccuracyMap, robot: RobotModel | None = None) -> Path:
    """Write the map atomically (a failed write leaves the previous file as it was)."""
    return atomic_write_json(path, accuracy_map_dict(amap, robot))


def _finite(v) -> bool:
    try:
        return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(float(v))
    except OverflowError:
        return False


def _point(value, size: int, path, name: str) -> np.ndarray:
    if value is None:
        return np.full(size, np.nan)
    if not isinstance(value, list) or len(value) != size or not all(_finite(v) for v in value):
        raise RoboCalError(f"expected {size} numbers or null", source=path, field=name,
                           hint="Measure the accuracy map again on the Compensation page.")
    return np.array([float(v) for v in value])


def read_accuracy_map(path: str | Path, robot: RobotModel | None = None) -> AccuracyMap:
    """Read an accuracy map file back, joints through `robot` (None: all revolute, deg);
    RoboCalError naming the file and field otherwise."""
    data = read_json(path)
    check_format(data, FORMAT, MAJOR, path)
    base = require(data, "base", path)
    if not isinstance(base, list) or len(base) != 4:
        raise RoboCalError("expected a 4x4 matrix", source=path, field="base")
    base = np.array([_point(r, 4, path, f"base[{i}]") for i, r in enumerate(base)])
    if not np.all(np.isfinite(base)) or not np.allclose(base[3], [0, 0, 0, 1]) or not np.allclose(
            base[:3, :3] @ base[:3, :3].T, np.eye(3), atol=1e-6):
        raise RoboCalError("expected a 4x4 rigid transform (a rotation, last row 0 0 0 1)", source=path,
                           field="base")
    points = require(data, "points", path)
    if not isinstance(points, list) or not points:
        raise RoboCalError("expected a non-empty list of points", source=path, field="points")
    dof = robot.dof if robot is not None else next(
        (len(p["q_calibrated"]) for p in points if isinstance(p, dict) and isinstance(p.get("q_calibrated"), list)), 0)
    cols = {k: [] for k in ("target_mm", "nominal_mm", "calibrated_mm", "q_nominal", "q_calibrated")}
    notes = []
    for i, p in enumerate(points):
        if not isinstance(p, dict):
            raise RoboCalError("expected an object", source=path, field=f"points[{i}]")
        for key in cols:
            size = dof if key.startswith("q_") else 3
            cols[key].append(_point(p.get(key), size, path, f"points[{i}].{key}"))
        if not np.all(np.isfinite(cols["target_mm"][-1])):
            raise RoboCalError("a point without its target", source=path, field=f"points[{i}].target_mm")
        notes.append(text(p.get("note", ""), path, f"points[{i}].note"))
    arrays = {k: np.array(v).reshape(len(points), -1) for k, v in cols.items()}
    q_from_file = robot.q_from_file if robot is not None else np.deg2rad
    return AccuracyMap(arrays["target_mm"], arrays["nominal_mm"], arrays["calibrated_mm"],
                       q_from_file(arrays["q_nominal"]), q_from_file(arrays["q_calibrated"]), base,
                       text(data.get("measured_by", ""), path, "measured_by"), notes,
                       text(data.get("robot", ""), path, "robot"), bool(data.get("cancelled", False)))
