"""A stereo pair as two ROS camera_info YAML files (camera_calibration_parsers' layout, as
ROS's stereo calibrator writes left.yaml and right.yaml).

Each file: image_width, image_height, camera_name, camera_matrix, distortion_model
(plumb_bob or rational_polynomial), distortion_coefficients, rectification_matrix,
projection_matrix — each matrix as {rows, cols, data}. ROS lengths are metres.

The right camera's pose comes from the two rectifications and the right projection matrix:
P2 = K'·[I | t] with t = (−B, 0, 0) m for a side-by-side pair (P2[0,3] = −fx'·B), so
R = R2ᵀ·R1 and T = R2ᵀ·(t2 − t1). A pair calibrated camera by camera (P2 without translation)
needs the pose given: an OpenCV file with R and T (mm), such as stereo_calib's extrinsics.yml.
Rectification matrices printed with six decimals (as ROS writes them) are rotations only to
that rounding: they are taken as the nearest rotations, and a note says so.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from core.errors import RoboCalError
from core.stereo.completion import StereoParts, complete_stereo, pose_from_rectification
from core.stereo.importers.common import ImportedStereo, check_file, entry, load_yaml, numbers, whole
from core.stereo.importers.opencv import read_pose

MODELS = {"plumb_bob": 5, "rational_polynomial": 8}
M_TO_MM = 1000.0
PRINTED_TOL = 1e-4          # |R·Rᵀ − I| of a rotation printed with six decimals is below ~1e-5


def _matrix(data, key: str, shape, path) -> np.ndarray:
    block = entry(data, key, path)
    if not isinstance(block, dict):
        raise RoboCalError("expected rows, cols and data", source=path, field=key)
    values = numbers(entry(block, "data", path, key + "."), None, path, key + ".data")
    if shape is not None and values.size != shape[0] * shape[1]:
        raise RoboCalError(f"expected {shape[0]}x{shape[1]} = {shape[0] * shape[1]} numbers, got {values.size}",
                           source=path, field=key + ".data")
    return values.reshape(shape) if shape is not None else values


def read_camera_info(path) -> dict:
    """One camera_info file: size, K, D, rectification R and projection P (translation in mm)."""
    path = check_file(Path(path))
    data = load_yaml(path)
    if not isinstance(data, dict):
        raise RoboCalError("expected a map of named fields (a ROS camera_info file)", source=path)
    size = (whole(entry(data, "image_width", path), path, "image_width"),
            whole(entry(data, "image_height", path), path, "image_height"))
    model = entry(data, "distortion_model", path)
    if model not in MODELS:
        raise RoboCalError(f"distortion model {model!r:.40} is not supported (only plumb_bob and "
                           "rational_polynomial)", source=path, field="distortion_model",
                           hint="Calibrate the cameras with the pinhole model (plumb_bob).")
    D = _matrix(data, "distortion_coefficients", None, path)
    if D.size != MODELS[model]:
        raise RoboCalError(f"{model} needs {MODELS[model]} coefficients, got {D.size}", source=path,
                           field="distortion_coefficients")
    P = _matrix(data, "projection_matrix", (3, 4), path).copy()
    P[:, 3] *= M_TO_MM
    R, rounded = _rotation_as_printed(_matrix(data, "rectification_matrix", (3, 3), path))
    return {"size": size, "K": _matrix(data, "camera_matrix", (3, 3), path), "D": D,
            "R": R, "P": P, "path": path, "rounded": rounded}


def _rotation_as_printed(R: np.ndarray) -> tuple[np.ndarray, bool]:
    """A rectification matrix printed with few decimals (ROS writes six) is a rotation only to
    that rounding: within PRINTED_TOL it is taken as the nearest rotation (True: it was moved);
    anything further is left for the checks to refuse."""
    off = float(np.abs(R @ R.T - np.eye(3)).max())
    if off == 0.0 or off > PRINTED_TOL or np.linalg.det(R) <= 0:
        return R, False
    U, _, Vt = np.linalg.svd(R)
    return U @ Vt, True


def _translation(camera: dict) -> np.ndarray:
    """t of the projection matrix K'·[I | t] (mm)."""
    P = camera["P"]
    if not (P[0, 0] > 0 and P[1, 1] > 0 and P[1, 0] == 0 and np.allclose(P[2, :3], [0, 0, 1], atol=1e-9)):
        raise RoboCalError("not a projection matrix [[fx', 0, cx', Tx], [0, fy', cy', Ty], [0, 0, 1, 0]] with "
                           "positive focal lengths", source=camera["path"], field="projection_matrix",
                           hint="Export the camera_info files again.")
    return np.linalg.solve(P[:, :3], P[:, 3])


def read_ros_pair(left, right, pose=None) -> ImportedStereo:
    """The stereo pair of a left and a right camera_info file; `pose`: an OpenCV file with R, T
    (mm) when the files do not hold the right camera's pose."""
    a, b = read_camera_info(left), read_camera_info(right)
    source = f"{a['path']} + {b['path'].name}"
    if a["size"] != b["size"]:
        raise RoboCalError(f"the two cameras have different image sizes ({a['size'][0]}x{a['size'][1]} and "
                           f"{b['size'][0]}x{b['size'][1]} px); RoboCal needs one size", source=b["path"],
                           field="image_width")
    paths = [a["path"], b["path"]]
    notes = []
    t1, t2 = _translation(a), _translation(b)
    if pose is not None:
        R, T = read_pose(pose)
        paths.append(Path(pose))
        notes.append(f"the right camera's pose from {Path(pose).name}")
    elif np.linalg.norm(t2 - t1) > 1e-9:
        R, T = pose_from_rectification(a["R"], b["R"], a["P"], b["P"], source)
        notes.append("the right camera's pose from the rectification and projection matrices "
                     f"(baseline {np.linalg.norm(T):.2f} mm)")
    else:
        raise RoboCalError("the right camera's projection matrix holds no baseline (P[0,3] = 0): the files do not "
                           "say where the right camera is", source=b["path"], field="projection_matrix",
                           hint="Give the pose too: an OpenCV file with R and T in mm (e.g. extrinsics.yml).")
    if a["rounded"] or b["rounded"]:
        notes.append("the rectification matrices, printed with few decimals, taken as the nearest rotations")
    parts = StereoParts(a["size"], a["K"], a["D"], b["K"], b["D"], R, T)
    if pose is None:
        parts.R1, parts.R2, parts.P1, parts.P2 = a["R"], b["R"], a["P"], b["P"]
    sf, computed = complete_stereo(parts, source)
    if computed:
        notes.append("computed: " + ", ".join(computed))
    return ImportedStereo(sf, "ROS camera_info pair", paths, notes)
