"""Stereo calibrations written by OpenCV's cv2.FileStorage (YAML or XML) without RoboCal's
format tag: one file with both cameras and their pose, or the pair intrinsics.yml +
extrinsics.yml that OpenCV's samples/cpp/stereo_calib.cpp writes.

Fields (docs/file-formats.md): K1 (or M1), D1, K2 (or M2), D2, R, T; optional image_width,
image_height, E, F, R1, R2, P1, P2, Q. A file with the rectification R1, R2, P1, P2 and no R, T
(as MultiSense's ImageCalUtility writes extrinsics.yml) gives the pose through it:
R = R2ᵀ·R1, T = R2ᵀ·(t2 − t1) (core.stereo.completion.pose_from_rectification). Each an !!opencv-matrix or, as cv2.FileStorage reads
them too, a plain list (T: [x, y, z]; a matrix as its rows, or its values row by row); a
file that starts with a byte-order mark is read as without it. Lengths (T, the translations of P1, P2) are those of
the checkerboard square the calibration was given: `mm_per_unit` converts them to mm.
Without an image size in the file, `image_size` gives it; otherwise it is inferred from the
left principal point (a note says so).
"""
from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np

from core.errors import RoboCalError
from core.stereo.completion import StereoParts, complete_stereo, pose_from_rectification, scale_lengths
from core.stereo.file import node_int, node_matrix, open_storage
from core.stereo.importers.common import ImportedStereo

CAMERA_KEYS = {"K1": "M1", "K2": "M2"}                 # RoboCal/OpenCV name -> stereo_calib's name
SHAPES = {"K1": (3, 3), "K2": (3, 3), "R": (3, 3), "T": (3, 1), "E": (3, 3), "F": (3, 3),
          "R1": (3, 3), "R2": (3, 3), "P1": (3, 4), "P2": (3, 4), "Q": (4, 4)}
OPTIONAL = ("E", "F", "R1", "R2", "P1", "P2", "Q")
RECTIFICATION = ("R1", "R2", "P1", "P2")              # enough for the pose when R, T are absent
SHORTEST_BASELINE_MM = 1.0       # cameras closer than this are a length unit mistaken, not a stereo pair


def storage_keys(path: Path) -> set[str] | None:
    """The top-level names of a FileStorage file, or None when OpenCV cannot read it as a map."""
    fs = open_storage(path, cv2.FILE_STORAGE_READ)
    if fs is None:
        return None
    try:
        root = fs.root()
        return set(root.keys()) if root.isMap() else None
    except cv2.error:
        return None
    finally:
        fs.release()


def _matrices(path: Path, wanted: dict[str, bool]) -> tuple[dict, tuple[int, int] | None]:
    """{key: matrix} of the wanted keys (True: required), and the image size if the file has one."""
    fs = open_storage(path, cv2.FILE_STORAGE_READ)
    if fs is None:
        raise RoboCalError("not a readable OpenCV YAML/XML file", source=path)
    out = {}
    try:
        for key, required in wanted.items():
            name = key
            if fs.getNode(key).empty() and key in CAMERA_KEYS and not fs.getNode(CAMERA_KEYS[key]).empty():
                name = CAMERA_KEYS[key]
            if fs.getNode(name).empty():
                if required:
                    alt = f" (or {CAMERA_KEYS[key]})" if key in CAMERA_KEYS else ""
                    raise RoboCalError(f"missing{alt}", source=path, field=key,
                                       hint="See docs/file-formats.md for the fields an OpenCV file needs.")
                continue
            m = node_matrix(fs, name, path)
            if key in SHAPES:
                shape = SHAPES[key]
                flat = m.shape[1] == 1 and m.size == shape[0] * shape[1]      # a plain list, row by row
                if not (m.shape == shape or (key == "T" and m.size == 3) or flat):
                    raise RoboCalError(f"expected a {shape[0]}x{shape[1]} matrix, got {m.shape[0]}x{m.shape[1]}",
                                       source=path, field=name)
                m = m.reshape(shape)
            elif min(m.shape) != 1:
                raise RoboCalError(f"expected the distortion coefficients in one row, got a "
                                   f"{m.shape[0]}x{m.shape[1]} matrix", source=path, field=name)
            out[key] = m
        size = None
        if not fs.getNode("image_width").empty() or not fs.getNode("image_height").empty():
            size = (node_int(fs, "image_width", path), node_int(fs, "image_height", path))
    except cv2.error as exc:
        raise RoboCalError(f"malformed OpenCV file ({str(exc).strip().splitlines()[-1]})", source=path) from None
    finally:
        fs.release()
    return out, size


#: sensor sizes of common machine-vision and USB cameras (w, h px)
COMMON_SIZES = ((640, 480), (640, 512), (752, 480), (800, 600), (1024, 768), (1280, 720), (1280, 960),
                (1280, 1024), (1440, 1080), (1600, 1200), (1920, 1080), (1920, 1200), (2048, 1536),
                (2448, 2048), (2592, 1944), (3840, 2160), (4096, 3000))


def infer_image_size(K1: np.ndarray) -> tuple[int, int]:
    """The image size whose centre is nearest the left principal point: a common camera size
    within 8 % of twice the principal point, else twice the principal point rounded to 8 px."""
    centre = 2 * np.array([K1[0, 2], K1[1, 2]])
    best = min(COMMON_SIZES, key=lambda s: float(np.abs(np.array(s) / centre - 1).max()))
    if float(np.abs(np.array(best) / centre - 1).max()) <= 0.08:
        return best
    return tuple(max(8, int(round(c / 8.0)) * 8) for c in centre)


def _pose(mats: dict, path: Path, notes: list[str], mm_per_unit: float) -> str:
    """R and T into `mats`: as the file gives them or, when it gives neither, from its
    rectification R1, R2, P1, P2 (a note says so); the field the baseline came from."""
    have = {"R", "T"} & mats.keys()
    if have == {"R", "T"}:
        return "T"
    if not have and all(key in mats for key in RECTIFICATION):
        R, T = pose_from_rectification(*(mats[key] for key in RECTIFICATION), path)
        mats["R"], mats["T"] = R, T.reshape(3, 1)
        notes.append("the right camera's pose from the rectification R1, R2, P1, P2 (the file holds no R, T): "
                     f"baseline {np.linalg.norm(T) * mm_per_unit:.2f} mm")
        return "P2"
    raise RoboCalError("missing", source=path, field="T" if "R" in have else "R",
                       hint="Give R and T (the right camera's pose), or the rectification R1, R2, P1, P2 it "
                            "gives; see docs/file-formats.md.")


def _import(parts_of: dict, size, paths: list[Path], kind: str, image_size, mm_per_unit: float,
            source, notes: list[str], pose_field: str) -> ImportedStereo:
    notes = list(notes)
    if image_size is not None:
        size = tuple(int(v) for v in image_size)
    elif size is None:
        size = infer_image_size(parts_of["K1"])
        notes.append(f"the file gives no image size: {size[0]}x{size[1]} px assumed (the common camera size "
                     "nearest twice the left principal point); give the image size if it differs")
    baseline = float(np.linalg.norm(parts_of["T"])) * mm_per_unit
    if 0 < baseline < SHORTEST_BASELINE_MM:
        raise RoboCalError(f"the cameras are {baseline:.3g} mm apart, too close for a stereo pair: the file's "
                           f"lengths are likely in another unit (in metres that is {baseline:.3g} m = "
                           f"{baseline * 1000:.1f} mm)", source=source, field=pose_field,
                           hint="Give the length unit the calibration used (robocal stereo-import --unit m, "
                                "cm or in).")
    parts = StereoParts(size, parts_of["K1"], parts_of["D1"], parts_of["K2"], parts_of["D2"], parts_of["R"],
                        parts_of["T"].reshape(3), **{k: parts_of.get(k) for k in OPTIONAL})
    sf, computed = complete_stereo(scale_lengths(parts, mm_per_unit), source)
    if computed:
        notes.append("computed from R and T: " + ", ".join(computed))
    return ImportedStereo(sf, kind, paths, notes)


def read_opencv(path, *, image_size=None, mm_per_unit: float = 1.0) -> ImportedStereo:
    """One OpenCV FileStorage file holding both cameras and their pose."""
    path = Path(path)
    wanted = {"K1": True, "D1": True, "K2": True, "D2": True, "R": False, "T": False,
              **{k: False for k in OPTIONAL}}
    mats, size = _matrices(path, wanted)
    notes: list[str] = []
    pose_field = _pose(mats, path, notes, mm_per_unit)
    return _import(mats, size, [path], "OpenCV FileStorage", image_size, mm_per_unit, path, notes, pose_field)


def read_opencv_pair(intrinsics, extrinsics, *, image_size=None, mm_per_unit: float = 1.0) -> ImportedStereo:
    """OpenCV's stereo_calib sample output: intrinsics.yml (M1, D1, M2, D2) and extrinsics.yml
    (R, T, R1, R2, P1, P2, Q; or, as MultiSense's ImageCalUtility writes it, R1, P1, R2, P2 alone)."""
    intrinsics, extrinsics = Path(intrinsics), Path(extrinsics)
    cams, size = _matrices(intrinsics, {"K1": True, "D1": True, "K2": True, "D2": True})
    pose, size2 = _matrices(extrinsics, {"R": False, "T": False, **{k: False for k in OPTIONAL}})
    notes: list[str] = []
    pose_field = _pose(pose, extrinsics, notes, mm_per_unit)
    if size is not None and size2 is not None and size != size2:
        raise RoboCalError(f"image size {size2[0]}x{size2[1]} differs from {size[0]}x{size[1]} in {intrinsics}",
                           source=extrinsics, field="image_width")
    return _import({**cams, **pose}, size or size2, [intrinsics, extrinsics],
                   "OpenCV stereo_calib intrinsics + extrinsics", image_size, mm_per_unit,
                   f"{intrinsics} + {extrinsics.name}", notes, pose_field)


def read_pose(path) -> tuple[np.ndarray, np.ndarray]:
    """R and T (mm) of the right camera from an OpenCV file (e.g. extrinsics.yml)."""
    mats, _ = _matrices(Path(path), {"R": True, "T": True})
    return mats["R"], mats["T"].reshape(3)
