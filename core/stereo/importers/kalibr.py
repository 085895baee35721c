"""A stereo pair from a Kalibr camchain.yaml (cam0 = left, cam1 = right), or the OpenVINS
kalibr_imucam_chain.yaml layout of the same fields.

Per camera: camera_model (pinhole), intrinsics [fu, fv, pu, pv] px, distortion_model (radtan
or none), distortion_coeffs [k1, k2, r1, r2] (radtan: OpenCV's k1, k2, p1, p2), resolution
[width, height] px. The pose of cam1 (metres; X_cam1 = T_cam1_cam0 · X_cam0, so R is its
rotation and T its translation × 1000 mm), the first of:

- cam1.T_cn_cnm1, Kalibr's transform from cam0 to cam1 coordinates, itself;
- both cameras' T_cam_imu (Kalibr's camchain-imucam, IMU → camera): T_cam1_imu · T_cam0_imu⁻¹;
- both cameras' T_imu_cam (OpenVINS, camera → IMU): T_imu_cam1⁻¹ · T_imu_cam0.

The two chains through the IMU are exact (rigid transforms composed). A file with OpenCV's
`%YAML:1.0` header is read like any other. Kalibr's equidistant (fisheye) and fov models, and
camera models other than pinhole, are refused with what to do.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from core.errors import RoboCalError
from core.stereo.completion import StereoParts, complete_stereo
from core.stereo.importers.common import ImportedStereo, check_file, entry, load_yaml, numbers, whole

M_TO_MM = 1000.0
RECALIBRATE = ("Calibrate the pair again with Kalibr's pinhole-radtan model, or with `robocal stereo-calibrate` "
               "on checkerboard images of these cameras.")


def _camera(data, name: str, path) -> dict:
    cam = entry(data, name, path)
    if not isinstance(cam, dict):
        raise RoboCalError("expected the camera's fields", source=path, field=name)
    model = entry(cam, "camera_model", path, name + ".")
    if model != "pinhole":
        raise RoboCalError(f"camera model {model!r:.40} is not supported (only pinhole)", source=path,
                           field=f"{name}.camera_model", hint=RECALIBRATE)
    dist = entry(cam, "distortion_model", path, name + ".")
    if dist in ("equidistant", "equi", "fisheye"):
        raise RoboCalError("an equidistant (fisheye) lens model: RoboCal's marker location uses OpenCV's pinhole "
                           "model with radial-tangential distortion, and the two do not convert into each other "
                           "exactly", source=path, field=f"{name}.distortion_model", hint=RECALIBRATE)
    if dist not in ("radtan", "none"):
        raise RoboCalError(f"distortion model {dist!r:.40} is not supported (only radtan): OpenCV's pinhole "
                           "model has no equivalent", source=path, field=f"{name}.distortion_model",
                           hint=RECALIBRATE)
    fu, fv, pu, pv = numbers(entry(cam, "intrinsics", path, name + "."), (4,), path, f"{name}.intrinsics")
    coeffs = (numbers(entry(cam, "distortion_coeffs", path, name + "."), (4,), path, f"{name}.distortion_coeffs")
              if dist == "radtan" else np.zeros(4))
    res = entry(cam, "resolution", path, name + ".")
    if not isinstance(res, list) or len(res) != 2:
        raise RoboCalError("expected [width, height]", source=path, field=f"{name}.resolution")
    size = (whole(res[0], path, f"{name}.resolution"), whole(res[1], path, f"{name}.resolution"))
    return {"K": np.array([[fu, 0.0, pu], [0.0, fv, pv], [0.0, 0.0, 1.0]]), "D": np.append(coeffs, 0.0),
            "size": size, "data": cam}


def read_kalibr(path) -> ImportedStereo:
    """cam0 and cam1 of a camchain.yaml as a RoboCal stereo pair."""
    path = check_file(Path(path))
    data = load_yaml(path)
    if not isinstance(data, dict):
        raise RoboCalError("expected cam0, cam1, … at the top level (a Kalibr camchain)", source=path)
    left, right = _camera(data, "cam0", path), _camera(data, "cam1", path)
    if left["size"] != right["size"]:
        raise RoboCalError(f"cam0 and cam1 have different resolutions ({left['size']} and {right['size']}); "
                           "RoboCal needs one size", source=path, field="cam1.resolution")
    M, pose_field, how = _cam1_from_cam0(left["data"], right["data"], path)
    notes = [f"cam0 is the left camera, cam1 the right (baseline {np.linalg.norm(M[:3, 3]) * M_TO_MM:.2f} mm)",
             "computed from R and T: E, F, R1, R2, P1, P2, Q"] + ([how] if how else [])
    others = sorted(k for k in data if isinstance(k, str) and k.startswith("cam") and k not in ("cam0", "cam1"))
    if others:
        notes.append("ignored: " + ", ".join(others))
    parts = StereoParts(left["size"], left["K"], left["D"], right["K"], right["D"], M[:3, :3], M[:3, 3] * M_TO_MM)
    try:
        sf, _ = complete_stereo(parts, path)
    except RoboCalError as exc:          # name Kalibr's fields rather than RoboCal's
        exc.field = {"K1": "cam0.intrinsics", "K2": "cam1.intrinsics", "R": pose_field,
                     "T": pose_field}.get(exc.field, exc.field)
        raise RoboCalError(exc.problem, source=exc.source, field=exc.field, hint=exc.hint) from None
    return ImportedStereo(sf, "Kalibr camchain" if how is None else "Kalibr/OpenVINS IMU-camera chain", [path],
                          notes)


def _transform(cam: dict, key: str, name: str, path) -> np.ndarray:
    """A 4x4 rigid transform (metres) of a camera's fields, its rotation checked."""
    field = f"{name}.{key}"
    M = numbers(entry(cam, key, path, name + "."), (4, 4), path, field)
    if not np.allclose(M[3], [0, 0, 0, 1], atol=1e-9):
        raise RoboCalError("the last row must be [0, 0, 0, 1]", source=path, field=field)
    R = M[:3, :3]
    if not (np.allclose(R @ R.T, np.eye(3), atol=1e-6) and np.linalg.det(R) > 0):
        raise RoboCalError("the upper-left 3x3 is not a rotation", source=path, field=field,
                           hint="Write the transform again with the tool that made it.")
    return M


def _cam1_from_cam0(cam0: dict, cam1: dict, path) -> tuple[np.ndarray, str, str | None]:
    """T_cam1_cam0 (4x4, metres), the field it came from, and a note when it was composed."""
    if "T_cn_cnm1" in cam1:
        return _transform(cam1, "T_cn_cnm1", "cam1", path), "cam1.T_cn_cnm1", None
    for key, compose, words in (
            ("T_cam_imu", lambda a, b: b @ np.linalg.inv(a), "T_cam1_imu · T_cam0_imu⁻¹ (Kalibr's IMU-camera chain)"),
            ("T_imu_cam", lambda a, b: np.linalg.inv(b) @ a, "T_imu_cam1⁻¹ · T_imu_cam0 (OpenVINS)")):
        if key in cam0 and key in cam1:
            M = compose(_transform(cam0, key, "cam0", path), _transform(cam1, key, "cam1", path))
            return M, f"cam1.{key}", f"the pose of cam1 from cam0 composed from both cameras' {key}: {words}"
    raise RoboCalError("missing: the pose of cam1 (T_cn_cnm1, or T_cam_imu / T_imu_cam on both cameras)",
                       source=path, field="cam1.T_cn_cnm1",
                       hint="Give the camchain Kalibr wrote for both cameras (it holds T_cn_cnm1).")
