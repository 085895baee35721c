"""MATLAB's stereoParameters as a RoboCal stereo pair: the one place for MATLAB's conventions,
shared by the JSON export (read here) and the MAT-file (core.stereo.importers.matlab_mat).

JSON:  s = toStruct(stereoParams);
       fid = fopen('stereoParams.json', 'w'); fprintf(fid, '%s', jsonencode(s)); fclose(fid);
MAT:   s = toStruct(stereoParams); save('stereo.mat', 's')   (or save('stereo.mat', '-struct', 's'))

Fields read (a matrix as MATLAB holds it; jsonencode writes it as a list of rows):
  CameraParameters1, CameraParameters2 (camera 1 = left, camera 2 = right), each with one of
    K                     3x3 [fx s cx; 0 fy cy; 0 0 1] (R2022b and later)
    IntrinsicMatrix       3x3, MATLAB's TRANSPOSED form [fx 0 0; s fy 0; cx cy 1]: K = IntrinsicMatrixᵀ
    Intrinsics            a cameraIntrinsics struct: FocalLength [fx fy], PrincipalPoint [cx cy], Skew
                          (its ImageSize and distortion are read when the camera has none)
  and
    RadialDistortion      [k1 k2], [k1 k2 k3] or [k1 k2 k3 k4 k5 k6] (OpenCV's rational model)
    TangentialDistortion  [p1 p2] (absent: 0 0)
    ImageSize             [rows cols] = [height width] px
  the pose of camera 2, one of
    RotationOfCamera2, TranslationOfCamera2   MATLAB's row-vector form x2 = x1·RotationOfCamera2 +
                          TranslationOfCamera2: OpenCV's R = RotationOfCamera2ᵀ, T = TranslationOfCamera2ᵀ
    PoseCamera2           a rigidtform3d struct (R, Translation) mapping camera 2 coordinates into
                          camera 1's: X1 = R·X2 + Translationᵀ, so OpenCV's R = PoseCamera2.Rᵀ and
                          T = −PoseCamera2.Rᵀ·Translationᵀ
  WorldUnits              of the translation: mm (millimeters), cm, m (meters), in (inches); at the
                          top or in CameraParameters1 (toStruct puts it there); absent: mm

MATLAB's pixel centres start at (1, 1), OpenCV's at (0, 0): the principal point is moved by
−1 px (as MATLAB's stereoParametersToOpenCV does). A skew other than 0 and fisheye cameras
(MappingCoefficients, fisheyeParameters) are refused: OpenCV's pinhole model has neither.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from core.errors import RoboCalError
from core.stereo.completion import StereoParts, complete_stereo
from core.stereo.importers.common import ImportedStereo, check_file, entry, load_json, numbers, whole

UNITS_MM = {"mm": 1.0, "millimeters": 1.0, "millimetres": 1.0, "cm": 10.0, "centimeters": 10.0,
            "centimetres": 10.0, "m": 1000.0, "meters": 1000.0, "metres": 1000.0, "in": 25.4, "inches": 25.4}
FISHEYE = ("MappingCoefficients", "StretchMatrix", "DistortionCenter")
SAVE_STRUCT = "s = toStruct(stereoParams); save('stereo.mat', 's', '-v7')"


@dataclass(frozen=True)
class MatlabObject:
    """A MATLAB class object in a MAT-file (e.g. a stereoParameters or rigidtform3d), which only
    MATLAB can read."""


def struct(data, key: str, source, prefix: str) -> dict:
    """data[key] as a struct (dict), or a RoboCalError naming the field."""
    value = entry(data, key, source, prefix)
    if isinstance(value, MatlabObject):
        raise RoboCalError("a MATLAB object, which only MATLAB can read", source=source, field=prefix + key,
                           hint=f"Save the struct of the stereo parameters instead: {SAVE_STRUCT}.")
    if not isinstance(value, dict):
        raise RoboCalError("expected a struct of named fields", source=source, field=prefix + key)
    return value


def _camera(data, name: str, path, prefix: str) -> dict:
    """K (OpenCV's, pixel centres from 0), D (OpenCV order), size (w, h) of CameraParameters1/2."""
    where = prefix + name
    cam = struct(data, name, path, prefix)
    inner = struct(cam, "Intrinsics", path, where + ".") if "Intrinsics" in cam else {}

    def pick(key, required=True):
        """(value, field) of key in the camera, else in its Intrinsics; (None, field) when absent
        and not required."""
        for fields, at in ((cam, where), (inner, where + ".Intrinsics")):
            if key in fields:
                return fields[key], f"{at}.{key}"
        if required:
            raise RoboCalError("missing", source=path, field=f"{where}{'.Intrinsics' if inner else ''}.{key}",
                               hint="See docs/file-formats.md for the fields this format needs.")
        return None, None

    for key in FISHEYE:
        if key in cam or key in inner:
            raise RoboCalError("a fisheye camera model (MATLAB's fisheyeParameters), which OpenCV's pinhole model "
                               "(and RoboCal) cannot use", source=path, field=pick(key)[1],
                               hint="Calibrate the cameras with MATLAB's standard (pinhole) camera model.")
    if "K" in cam:
        field = f"{where}.K"
        K = numbers(cam["K"], (3, 3), path, field)
    elif "IntrinsicMatrix" in cam:
        field = f"{where}.IntrinsicMatrix"
        K = numbers(cam["IntrinsicMatrix"], (3, 3), path, field).T
    elif "FocalLength" in cam or "FocalLength" in inner:
        focal, field = pick("FocalLength")
        fx, fy = numbers(focal, (2,), path, field)
        centre, centre_field = pick("PrincipalPoint")
        cx, cy = numbers(centre, (2,), path, centre_field)
        skew, skew_field = pick("Skew", required=False)
        s = numbers(skew, (1,), path, skew_field)[0] if skew is not None else 0.0      # px
        K = np.array([[fx, s, cx], [0.0, fy, cy], [0.0, 0.0, 1.0]])
    else:
        raise RoboCalError("missing (the camera needs K, IntrinsicMatrix or Intrinsics)", source=path,
                           field=f"{where}.K", hint="See docs/file-formats.md for the fields this format needs.")
    if abs(K[0, 1]) > 1e-9 * max(abs(K[0, 0]), 1.0):
        raise RoboCalError(f"the skew is {K[0, 1]:g}, which OpenCV's camera model (and RoboCal) cannot use",
                           source=path, field=field, hint="Calibrate again with EstimateSkew false.")
    K = K.copy()
    K[0, 2] -= 1.0                 # MATLAB's first pixel centre is (1, 1), OpenCV's (0, 0)
    K[1, 2] -= 1.0
    value, radial_field = pick("RadialDistortion")
    radial = numbers(value, None, path, radial_field)
    if radial.size not in (2, 3, 6):
        raise RoboCalError(f"expected 2, 3 or 6 coefficients, got {radial.size}", source=path, field=radial_field)
    value, tangential_field = pick("TangentialDistortion", required=False)
    tangential = numbers(value, (2,), path, tangential_field) if value is not None else np.zeros(2)
    k = np.concatenate([radial, np.zeros(3 - radial.size)]) if radial.size < 3 else radial
    D = np.concatenate([k[:2], tangential, k[2:]])
    rows_cols, size_field = pick("ImageSize")
    if not isinstance(rows_cols, list) or len(rows_cols) != 2:
        raise RoboCalError("expected [rows cols]", source=path, field=size_field)
    h, w = (whole(v, path, size_field) for v in rows_cols)
    return {"K": K, "D": D, "size": (w, h), "field": field, "size_field": size_field}


def _pose(data, path, prefix: str) -> tuple[np.ndarray, np.ndarray, str, str]:
    """OpenCV's R and T (world units) of camera 2, and the fields they came from."""
    if "RotationOfCamera2" in data or "PoseCamera2" not in data:
        R = numbers(entry(data, "RotationOfCamera2", path, prefix), (3, 3), path, prefix + "RotationOfCamera2").T
        T = numbers(entry(data, "TranslationOfCamera2", path, prefix), (3,), path, prefix + "TranslationOfCamera2")
        return R, T, prefix + "RotationOfCamera2", prefix + "TranslationOfCamera2"
    where = prefix + "PoseCamera2"
    pose = struct(data, "PoseCamera2", path, prefix)
    Rp = numbers(entry(pose, "R", path, where + "."), (3, 3), path, where + ".R")
    tp = numbers(entry(pose, "Translation", path, where + "."), (3,), path, where + ".Translation")
    return Rp.T, -Rp.T @ tp, where + ".R", where + ".Translation"


def _unit(data, path, prefix: str) -> tuple[str, float]:
    """WorldUnits (top level, else CameraParameters1's, else mm) and its length in mm."""
    cam = data.get("CameraParameters1")
    if "WorldUnits" in data:
        unit, field = data["WorldUnits"], prefix + "WorldUnits"
    elif isinstance(cam, dict) and "WorldUnits" in cam:
        unit, field = cam["WorldUnits"], prefix + "CameraParameters1.WorldUnits"
    else:
        return "mm", 1.0
    if not isinstance(unit, str) or unit.strip().lower() not in UNITS_MM:
        raise RoboCalError(f"unknown world unit {unit!r:.40}", source=path, field=field,
                           hint="Use mm, cm, m or in.")
    return unit, UNITS_MM[unit.strip().lower()]


def stereo_from_struct(data, path, kind: str, prefix: str = "") -> ImportedStereo:
    """The stereo pair of a stereoParameters struct (a dict of MATLAB's fields, matrices as lists
    of rows); `prefix` names the fields in messages (e.g. "s." for the MAT variable s)."""
    if not isinstance(data, dict):
        raise RoboCalError("expected a struct with CameraParameters1, CameraParameters2 and the pose of camera 2 "
                           "(RotationOfCamera2 and TranslationOfCamera2, or PoseCamera2)", source=path)
    left, right = _camera(data, "CameraParameters1", path, prefix), _camera(data, "CameraParameters2", path, prefix)
    if left["size"] != right["size"]:
        raise RoboCalError("the two cameras have different image sizes; RoboCal needs one size", source=path,
                           field=right["size_field"])
    unit, scale = _unit(data, path, prefix)
    R, T, r_field, t_field = _pose(data, path, prefix)
    parts = StereoParts(left["size"], left["K"], left["D"], right["K"], right["D"], R, T * scale)
    try:
        sf, computed = complete_stereo(parts, path)
    except RoboCalError as exc:          # name MATLAB's fields rather than RoboCal's
        field = {"K1": left["field"], "K2": right["field"], "R": r_field, "T": t_field}.get(exc.field, exc.field)
        raise RoboCalError(exc.problem, source=exc.source, field=field, hint=exc.hint) from None
    notes = ["principal points moved by −1 px (MATLAB counts pixels from 1)",
             "computed from R and T: " + ", ".join(computed)]
    if scale != 1.0:
        notes.append(f"translation converted from {unit} to mm")
    return ImportedStereo(sf, kind, [Path(path)], notes)


def read_matlab(path) -> ImportedStereo:
    """stereoParameters exported as JSON (toStruct + jsonencode)."""
    path = check_file(Path(path))
    return stereo_from_struct(load_json(path), path, "MATLAB stereoParameters (JSON)")
