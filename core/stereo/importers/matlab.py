"""A stereo pair exported from MATLAB's stereoParameters as JSON:

    s = toStruct(stereoParams);
    fid = fopen('stereoParams.json', 'w'); fprintf(fid, '%s', jsonencode(s)); fclose(fid);

Fields read (jsonencode writes a matrix as a list of rows):
  CameraParameters1, CameraParameters2:
    IntrinsicMatrix       3x3, MATLAB's TRANSPOSED form [fx 0 0; s fy 0; cx cy 1] (or K, not transposed)
    RadialDistortion      [k1 k2] or [k1 k2 k3]
    TangentialDistortion  [p1 p2] (absent: 0 0)
    ImageSize             [rows cols] = [height width] px
  RotationOfCamera2       3x3, TRANSPOSED: OpenCV's R = RotationOfCamera2ᵀ
  TranslationOfCamera2    [x y z] in WorldUnits: OpenCV's T
  WorldUnits              mm (millimeters), cm, m (meters), in (inches); absent: mm

MATLAB's pixel centres start at (1, 1), OpenCV's at (0, 0): the principal point is moved by
−1 px (as MATLAB's stereoParametersToOpenCV does). A skew other than 0 is refused.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from core.errors import RoboCalError
from core.stereo.completion import StereoParts, complete_stereo
from core.stereo.importers.common import ImportedStereo, check_file, entry, load_json, numbers, whole

UNITS_MM = {"mm": 1.0, "millimeters": 1.0, "millimetres": 1.0, "cm": 10.0, "centimeters": 10.0,
            "centimetres": 10.0, "m": 1000.0, "meters": 1000.0, "metres": 1000.0, "in": 25.4, "inches": 25.4}


def _camera(data, name: str, path) -> dict:
    cam = entry(data, name, path)
    if not isinstance(cam, dict):
        raise RoboCalError("expected the camera's fields", source=path, field=name)
    if "K" in cam:
        K = numbers(cam["K"], (3, 3), path, f"{name}.K")
    else:
        K = numbers(entry(cam, "IntrinsicMatrix", path, name + "."), (3, 3), path, f"{name}.IntrinsicMatrix").T
    field = f"{name}.K" if "K" in cam else f"{name}.IntrinsicMatrix"
    if abs(K[0, 1]) > 1e-9 * max(abs(K[0, 0]), 1.0):
        raise RoboCalError(f"the skew is {K[0, 1]:g}, which OpenCV's camera model (and RoboCal) cannot use",
                           source=path, field=field, hint="Calibrate again with EstimateSkew false.")
    K = K.copy()
    K[0, 2] -= 1.0                 # MATLAB's first pixel centre is (1, 1), OpenCV's (0, 0)
    K[1, 2] -= 1.0
    radial = numbers(entry(cam, "RadialDistortion", path, name + "."), None, path, f"{name}.RadialDistortion")
    if radial.size not in (2, 3):
        raise RoboCalError(f"expected 2 or 3 coefficients, got {radial.size}", source=path,
                           field=f"{name}.RadialDistortion")
    tangential = (numbers(cam["TangentialDistortion"], (2,), path, f"{name}.TangentialDistortion")
                  if "TangentialDistortion" in cam else np.zeros(2))
    D = np.array([radial[0], radial[1], tangential[0], tangential[1], radial[2] if radial.size == 3 else 0.0])
    rows_cols = entry(cam, "ImageSize", path, name + ".")
    if not isinstance(rows_cols, list) or len(rows_cols) != 2:
        raise RoboCalError("expected [rows cols]", source=path, field=f"{name}.ImageSize")
    h, w = (whole(v, path, f"{name}.ImageSize") for v in rows_cols)
    return {"K": K, "D": D, "size": (w, h), "field": field}


def read_matlab(path) -> ImportedStereo:
    """stereoParameters exported as JSON (toStruct + jsonencode)."""
    path = check_file(Path(path))
    data = load_json(path)
    if not isinstance(data, dict):
        raise RoboCalError("expected an object with CameraParameters1, CameraParameters2, RotationOfCamera2 and "
                           "TranslationOfCamera2", source=path)
    left, right = _camera(data, "CameraParameters1", path), _camera(data, "CameraParameters2", path)
    if left["size"] != right["size"]:
        raise RoboCalError("the two cameras have different image sizes; RoboCal needs one size", source=path,
                           field="CameraParameters2.ImageSize")
    unit = data.get("WorldUnits", "mm")
    if not isinstance(unit, str) or unit.strip().lower() not in UNITS_MM:
        raise RoboCalError(f"unknown world unit {unit!r:.40}", source=path, field="WorldUnits",
                           hint="Use mm, cm, m or in.")
    scale = UNITS_MM[unit.strip().lower()]
    R = numbers(entry(data, "RotationOfCamera2", path), (3, 3), path, "RotationOfCamera2").T
    T = numbers(entry(data, "TranslationOfCamera2", path), (3,), path, "TranslationOfCamera2") * scale
    parts = StereoParts(left["size"], left["K"], left["D"], right["K"], right["D"], R, T)
    try:
        sf, computed = complete_stereo(parts, path)
    except RoboCalError as exc:          # name MATLAB's fields rather than RoboCal's
        field = {"K1": left["field"], "K2": right["field"], "R": "RotationOfCamera2",
                 "T": "TranslationOfCamera2"}.get(exc.field, exc.field)
        raise RoboCalError(exc.problem, source=exc.source, field=field, hint=exc.hint) from None
    notes = ["principal points moved by −1 px (MATLAB counts pixels from 1)",
             "computed from R and T: " + ", ".join(computed)]
    if scale != 1.0:
        notes.append(f"translation converted from {unit} to mm")
    return ImportedStereo(sf, "MATLAB stereoParameters (JSON)", [path], notes)
