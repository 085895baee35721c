"""Stereo calibration files as other tools write them, made from each format's public
description (never from RoboCal's writers): OpenCV FileStorage (stereo.yml, and stereo_calib's
intrinsics.yml + extrinsics.yml), ROS camera_info (camera_calibration_parsers' YAML), Kalibr
camchain.yaml and MATLAB stereoParameters as jsonencode(toStruct(...)) and in a MAT-file."""
from __future__ import annotations

import json
from pathlib import Path

import cv2
import numpy as np

from core.stereo.rig import StereoRig


def rectify(rig: StereoRig):
    """cv2.stereoRectify of the rig, as OpenCV's sample calls it (R1, R2, P1, P2, Q)."""
    return cv2.stereoRectify(rig.left.K, rig.left.dist, rig.right.K, rig.right.dist, rig.left.size, rig.R,
                             rig.T.reshape(3, 1), flags=cv2.CALIB_ZERO_DISPARITY, alpha=0)[:5]


def opencv_file(rig: StereoRig, path: Path, *, rectification=True, camera_names=("K1", "K2"),
                size=True, extra: dict | None = None) -> Path:
    """One FileStorage file (YAML or XML by the suffix) as a program using OpenCV writes it."""
    fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_WRITE)
    if size:
        fs.write("image_width", rig.left.size[0])
        fs.write("image_height", rig.left.size[1])
    fs.write(camera_names[0], rig.left.K)
    fs.write("D1", rig.left.dist.reshape(1, -1))
    fs.write(camera_names[1], rig.right.K)
    fs.write("D2", rig.right.dist.reshape(1, -1))
    fs.write("R", rig.R)
    fs.write("T", rig.T.reshape(3, 1))
    if rectification:
        for key, m in zip(("R1", "R2", "P1", "P2", "Q"), rectify(rig)):
            fs.write(key, m)
    for key, m in (extra or {}).items():
        fs.write(key, m)
    fs.release()
    return path


def stereo_calib_pair(rig: StereoRig, folder: Path) -> tuple[Path, Path]:
    """intrinsics.yml and extrinsics.yml as samples/cpp/stereo_calib.cpp writes them
    (`fs << "M1" << cameraMatrix[0] << "D1" << ...`; `fs << "R" << R << "T" << T << "R1" ...`)."""
    fs = cv2.FileStorage(str(folder / "intrinsics.yml"), cv2.FILE_STORAGE_WRITE)
    for key, m in (("M1", rig.left.K), ("D1", rig.left.dist.reshape(1, -1)), ("M2", rig.right.K),
                   ("D2", rig.right.dist.reshape(1, -1))):
        fs.write(key, m)
    fs.release()
    fs = cv2.FileStorage(str(folder / "extrinsics.yml"), cv2.FILE_STORAGE_WRITE)
    fs.write("R", rig.R)
    fs.write("T", rig.T.reshape(3, 1))
    for key, m in zip(("R1", "R2", "P1", "P2", "Q"), rectify(rig)):
        fs.write(key, m)
    fs.release()
    return folder / "intrinsics.yml", folder / "extrinsics.yml"


def _ros_block(name, M):
    M = np.atleast_2d(np.asarray(M, float))
    return (f"{name}:\n  rows: {M.shape[0]}\n  cols: {M.shape[1]}\n"
            f"  data: [{', '.join(repr(float(v)) for v in M.ravel())}]\n")


def ros_pair(rig: StereoRig, folder: Path, *, with_baseline=True, model="plumb_bob") -> tuple[Path, Path]:
    """left.yaml and right.yaml in camera_calibration_parsers' layout; P's translation in metres."""
    R1, R2, P1, P2, _ = rectify(rig)
    out = []
    for side, cam, Rr, P in (("left", rig.left, R1, P1), ("right", rig.right, R2, P2)):
        P = np.array(P, float)
        P[:, 3] = P[:, 3] / 1000.0 if with_baseline else 0.0
        text = (f"image_width: {cam.size[0]}\nimage_height: {cam.size[1]}\ncamera_name: narrow_stereo/{side}\n"
                + _ros_block("camera_matrix", cam.K) + f"distortion_model: {model}\n"
                + _ros_block("distortion_coefficients", cam.dist[:5].reshape(1, 5))
                + _ros_block("rectification_matrix", Rr) + _ros_block("projection_matrix", P))
        out.append(folder / f"{side}.yaml")
        out[-1].write_text(text)
    return out[0], out[1]


def kalibr_camchain(rig: StereoRig, path: Path, *, model="radtan", camera_model="pinhole") -> Path:
    """camchain.yaml as Kalibr writes it: cam1's T_cn_cnm1 maps cam0 coordinates to cam1's, metres."""
    def cam(c):
        d = ", ".join(repr(float(v)) for v in c.dist[:4])
        k = ", ".join(repr(float(v)) for v in (c.K[0, 0], c.K[1, 1], c.K[0, 2], c.K[1, 2]))
        return (f"  camera_model: {camera_model}\n  distortion_coeffs: [{d}]\n"
                f"  distortion_model: {model}\n  intrinsics: [{k}]\n"
                f"  resolution: [{c.size[0]}, {c.size[1]}]\n")
    M = np.eye(4)
    M[:3, :3], M[:3, 3] = rig.R, rig.T / 1000.0
    rows = "".join(f"  - [{', '.join(repr(float(v)) for v in row)}]\n" for row in M)
    path.write_text("cam0:\n  cam_overlaps: [1]\n" + cam(rig.left) + "  rostopic: /cam0/image_raw\n"
                    "cam1:\n  T_cn_cnm1:\n" + rows + "  cam_overlaps: [0]\n" + cam(rig.right)
                    + "  rostopic: /cam1/image_raw\n")
    return path


def matlab_json(rig: StereoRig, path: Path, *, units="mm", skew=0.0) -> Path:
    """jsonencode(toStruct(stereoParams)): IntrinsicMatrix and RotationOfCamera2 transposed,
    principal point counted from pixel (1, 1), ImageSize [rows cols]; matrices as lists of rows."""
    scale = {"mm": 1.0, "meters": 0.001}[units]

    def cam(c):
        K = np.array(c.K, float)
        K[0, 1] = skew
        K[0, 2] += 1.0
        K[1, 2] += 1.0
        d = c.dist
        return {"IntrinsicMatrix": K.T.tolist(), "RadialDistortion": [d[0], d[1], d[4]],
                "TangentialDistortion": [d[2], d[3]], "ImageSize": [c.size[1], c.size[0]],
                "WorldUnits": units, "EstimateSkew": bool(skew), "NumRadialDistortionCoefficients": 3,
                "EstimateTangentialDistortion": True, "ReprojectionErrors": [[[0.1, -0.2]]]}
    data = {"CameraParameters1": cam(rig.left), "CameraParameters2": cam(rig.right),
            "RotationOfCamera2": rig.R.T.tolist(), "TranslationOfCamera2": (rig.T * scale).tolist(),
            "WorldUnits": units, "Version": {"Major": 1}}
    path.write_text(json.dumps(data))
    return path


def matlab_mat(rig: StereoRig, path: Path, *, layout="variable", intrinsics="IntrinsicMatrix",
               pose="RotationOfCamera2", units="mm", radial=3) -> Path:
    """A MAT-file (scipy.io.savemat, format 5 = MATLAB's -v7 container, compressed) as MATLAB saves
    toStruct(stereoParams), following MATLAB's documentation:

    layout      'variable': save('stereo.mat', 's') — one struct variable s;
                'fields': save('stereo.mat', '-struct', 's') — its fields as variables
    intrinsics  'IntrinsicMatrix': [fx 0 0; s fy 0; cx cy 1] (before R2022b); 'K': [fx s cx; 0 fy cy; 0 0 1];
                'Intrinsics': a cameraIntrinsics struct (FocalLength, PrincipalPoint, ImageSize,
                RadialDistortion, TangentialDistortion, Skew) — pixel centres counted from (1, 1)
    pose        'RotationOfCamera2': row-vector form x2 = x1·RotationOfCamera2 + TranslationOfCamera2;
                'PoseCamera2': rigidtform3d fields R, Translation mapping camera 2 coordinates to
                camera 1's (X1 = R·X2 + Translationᵀ)
    radial      2, 3 or 6 RadialDistortion coefficients (6: k1 k2 k3 k4 k5 k6, the rational model)"""
    from scipy.io import savemat

    scale = {"mm": 1.0, "meters": 0.001}[units]

    def cam(c):
        K = np.array(c.K, float)
        K[0, 2] += 1.0
        K[1, 2] += 1.0
        d = np.zeros(8)
        d[:c.dist.size] = c.dist
        k = {2: d[[0, 1]], 3: d[[0, 1, 4]], 6: d[[0, 1, 4, 5, 6, 7]]}[radial]
        size = np.array([c.size[1], c.size[0]], float)          # [rows cols]
        if intrinsics == "Intrinsics":
            return {"Intrinsics": {"FocalLength": np.array([K[0, 0], K[1, 1]]),
                                   "PrincipalPoint": np.array([K[0, 2], K[1, 2]]), "ImageSize": size,
                                   "RadialDistortion": k, "TangentialDistortion": d[2:4], "Skew": 0.0},
                    "WorldUnits": units}
        matrix = {"IntrinsicMatrix": K.T, "K": K}[intrinsics]
        return {intrinsics: matrix, "RadialDistortion": k, "TangentialDistortion": d[2:4], "ImageSize": size,
                "WorldUnits": units, "EstimateSkew": False, "NumRadialDistortionCoefficients": float(radial),
                "EstimateTangentialDistortion": True, "RotationVectors": np.zeros((2, 3)),
                "TranslationVectors": np.ones((2, 3)), "WorldPoints": np.zeros((4, 2)),
                "ReprojectionErrors": np.full((4, 2, 2), 0.1), "Version": {"Name": "Computer Vision Toolbox"}}
    s = {"CameraParameters1": cam(rig.left), "CameraParameters2": cam(rig.right),
         "Version": {"Name": "Computer Vision Toolbox"},
         "RectificationParams": {"Initialized": False, "OutputView": "same"}}
    T = rig.T * scale
    if pose == "RotationOfCamera2":
        s["RotationOfCamera2"] = rig.R.T
        s["TranslationOfCamera2"] = T
    else:
        s["PoseCamera2"] = {"Dimensionality": 3.0, "R": rig.R.T, "Translation": -rig.R.T @ T}
    savemat(path, s if layout == "fields" else {"s": s}, do_compression=True)
    return path
