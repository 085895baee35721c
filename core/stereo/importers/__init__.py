"""Stereo calibrations from RoboCal and from other tools, through one entry point.

`read_any_stereo(paths)` recognises the format by the files' contents (docs/file-formats.md):

- RoboCal's stereo.yaml (format: robocal.stereo/1);
- an OpenCV FileStorage YAML/XML file with K1 (M1), D1, K2 (M2), D2, R, T;
- OpenCV stereo_calib's intrinsics.yml + extrinsics.yml (either one: the other is taken from
  beside it); an extrinsics.yml with the rectification R1, R2, P1, P2 and no R, T too;
- two ROS camera_info files (left, right), optionally with an OpenCV file holding R, T;
- a Kalibr camchain.yaml (or an IMU-camera chain: Kalibr's T_cam_imu, OpenVINS' T_imu_cam);
- MATLAB stereoParameters as JSON or as a MAT-file (.mat).

A folder stands for the calibration inside it: intrinsics + extrinsics (or one pair of files
named *intrinsics* and *extrinsics* alike), left.yaml + right.yaml, one camchain*.yaml or one
stereo.yaml. What the files leave out is computed (core.stereo.completion), everything is
checked (core.stereo.checks), and statistics the files do not hold stay unknown.
"""
from __future__ import annotations

from pathlib import Path

from core.errors import RoboCalError
from core.stereo.importers.common import ImportedStereo, check_file, load_json, load_yaml

__all__ = ["ImportedStereo", "read_any_stereo", "FORMATS"]

FORMATS = ("RoboCal stereo.yaml, OpenCV FileStorage YAML/XML (K1 D1 K2 D2 R T), OpenCV stereo_calib "
           "intrinsics.yml + extrinsics.yml, ROS camera_info left + right, Kalibr camchain.yaml, MATLAB "
           "stereoParameters JSON or MAT-file")
_HINT = f"RoboCal reads: {FORMATS} (see docs/file-formats.md)."


def _kind(path: Path) -> str:
    """robocal, opencv, intrinsics, extrinsics, ros, kalibr, matlab or matlab_mat (by the file's
    fields; a MAT-file by its suffix)."""
    from core.stereo.importers.opencv import storage_keys

    if path.suffix.lower() == ".mat":
        check_file(path, text=False)
        return "matlab_mat"
    check_file(path)
    if path.suffix.lower() == ".json":
        data = load_json(path)
        if isinstance(data, dict) and "CameraParameters1" in data:
            return "matlab"
        raise RoboCalError("not a stereo calibration (a JSON file without CameraParameters1)", source=path,
                           hint=_HINT)
    keys = storage_keys(path)
    if keys is None:                   # not OpenCV's to read: plain YAML (also behind OpenCV's %YAML:1.0 header)
        text = path.read_text(encoding="utf-8-sig", errors="replace")
        try:
            data = load_yaml(path)
        except RoboCalError:
            if "opencv-matrix" in text or "<opencv_storage>" in text:
                raise RoboCalError("not a readable OpenCV YAML/XML file", source=path,
                                   hint="Check the file, or write it again with the program that made it.") from None
            raise
        keys = set(data) if isinstance(data, dict) else set()
    if "format" in keys:
        return "robocal"
    if "cam0" in keys:
        return "kalibr"
    if "camera_matrix" in keys:
        return "ros"
    cameras = bool(keys & {"K1", "M1"})
    pose = {"R", "T"} <= keys or {"R1", "R2", "P1", "P2"} <= keys        # the pose, or a rectification giving it
    if cameras and pose:
        return "opencv"
    if cameras:
        return "intrinsics"
    if pose:
        return "extrinsics"
    raise RoboCalError("not a stereo calibration RoboCal recognises", source=path, hint=_HINT)


def _sibling(path: Path, want: str) -> Path:
    """extrinsics.yml beside intrinsics.yml (or the other way round)."""
    have = "intrinsics" if want == "extrinsics" else "extrinsics"
    name = path.name.replace(have, want) if have in path.name else f"{want}{path.suffix}"
    other = path.with_name(name)
    if not other.is_file():
        raise RoboCalError(f"holds only the {'cameras' if have == 'intrinsics' else 'pose'} of a stereo pair, and "
                           f"there is no {name} beside it", source=path,
                           hint=f"Give both {have}.yml and {want}.yml.")
    return other


def _folder(folder: Path) -> list[Path]:
    """The calibration files in a folder."""
    for names in (("intrinsics.yml", "extrinsics.yml"), ("intrinsics.yaml", "extrinsics.yaml"),
                  ("intrinsics.xml", "extrinsics.xml"), ("left.yaml", "right.yaml"), ("stereo.yaml",)):
        if all((folder / n).is_file() for n in names):
            return [folder / n for n in names]
    pairs = [(p, p.with_name(p.name.replace("intrinsics", "extrinsics")))
             for p in sorted(folder.glob("*intrinsics*")) if p.suffix.lower() in (".yml", ".yaml", ".xml")]
    pairs = [list(pair) for pair in pairs if pair[1].is_file()]
    if len(pairs) == 1:                            # e.g. MultiSense's example_intrinsics.yml + example_extrinsics.yml
        return pairs[0]
    chains = sorted(folder.glob("*camchain*.yaml"))
    if len(chains) == 1:
        return chains
    raise RoboCalError("no stereo calibration found in this folder (looked for intrinsics.yml + extrinsics.yml "
                       "or one other *intrinsics* + *extrinsics* pair, left.yaml + right.yaml, stereo.yaml, one "
                       "*camchain*.yaml)", source=folder, hint="Give the calibration file(s) themselves.")


def read_any_stereo(paths, *, image_size: tuple[int, int] | None = None,
                    mm_per_unit: float = 1.0) -> ImportedStereo:
    """The stereo calibration held by `paths` (one path, or a list), in any supported format.

    `image_size` (w, h px) for files without one (OpenCV's stereo_calib output); `mm_per_unit`
    converts the lengths of OpenCV files calibrated with a square size in other units."""
    from core.stereo.file import read_stereo_yaml
    from core.stereo.importers.kalibr import read_kalibr
    from core.stereo.importers.matlab import read_matlab
    from core.stereo.importers.matlab_mat import read_matlab_mat
    from core.stereo.importers.opencv import read_opencv, read_opencv_pair
    from core.stereo.importers.ros import read_ros_pair

    paths = [Path(p) for p in ([paths] if isinstance(paths, (str, Path)) else paths)]
    if len(paths) == 1 and paths[0].is_dir():
        paths = _folder(paths[0])
    if not paths or len(paths) > 3:
        raise RoboCalError(f"expected one to three stereo calibration files, got {len(paths)}", hint=_HINT)
    kinds = [_kind(p) for p in paths]
    options = {"image_size": image_size, "mm_per_unit": mm_per_unit}
    if kinds == ["robocal"]:
        return ImportedStereo(read_stereo_yaml(paths[0]), "RoboCal stereo.yaml", paths)
    if kinds == ["opencv"]:
        return read_opencv(paths[0], **options)
    if kinds == ["kalibr"]:
        return read_kalibr(paths[0])
    if kinds == ["matlab"]:
        return read_matlab(paths[0])
    if kinds == ["matlab_mat"]:
        return read_matlab_mat(paths[0])
    if kinds == ["intrinsics"]:
        return read_opencv_pair(paths[0], _sibling(paths[0], "extrinsics"), **options)
    if kinds == ["extrinsics"]:
        return read_opencv_pair(_sibling(paths[0], "intrinsics"), paths[0], **options)
    if sorted(kinds) == ["extrinsics", "intrinsics"]:
        return read_opencv_pair(paths[kinds.index("intrinsics")], paths[kinds.index("extrinsics")], **options)
    if kinds == ["ros"]:
        raise RoboCalError("a ROS camera_info file holds one camera", source=paths[0],
                           hint="Give the left and the right camera_info files (in that order).")
    if kinds == ["ros", "ros"]:
        return read_ros_pair(*paths)
    if kinds == ["ros", "ros", "extrinsics"]:
        return read_ros_pair(paths[0], paths[1], pose=paths[2])
    listing = ", ".join(f"{p.name} ({k})" for p, k in zip(paths, kinds))
    raise RoboCalError(f"these files do not make one stereo calibration: {listing}", source=paths[0], hint=_HINT)
