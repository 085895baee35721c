"""`robocal stereo-import` and stereo files from other tools through `robocal locate`: a plain
OpenCV file locates the marker exactly as RoboCal's stereo.yaml of the same calibration."""
from __future__ import annotations

import json

import numpy as np
import pytest

from app.cli import main
from core.stereo.file import read_stereo_yaml
from tests.core.stereo import foreign_files as ff


@pytest.fixture(scope="module")
def dataset(tmp_path_factory):
    """A small virtual-lab dataset (marker images of 2 poses) and its cameras as a StereoRig."""
    from core.camera import CameraModel
    from core.stereo.rig import StereoRig
    from core.virtual_lab.dataset import simulate_dataset

    out = tmp_path_factory.mktemp("import_cli") / "ds"
    simulate_dataset(out, seed=3, pairs=0, poses=2)
    s = json.loads((out / "truth.json").read_text())["stereo"]
    size = (s["image_width"], s["image_height"])
    rig = StereoRig(CameraModel(s["K1"], s["D1"], *size), CameraModel(s["K2"], s["D2"], *size), s["R"], s["T"])
    return out, rig


def _locate(ds, stereo, pose, capsys):
    code = main(["locate", "--stereo", str(stereo), "--marker", str(ds / "marker" / "training.png"),
                 "--left", str(ds / "poses" / "left" / f"pose_{pose:03d}.png"),
                 "--right", str(ds / "poses" / "right" / f"pose_{pose:03d}.png"), "--json"])
    captured = capsys.readouterr()
    assert code == 0, captured.err
    d = json.loads(captured.out)
    return np.array([d["x"], d["y"], d["z"]])


def test_plain_opencv_file_locates_like_robocal_stereo_yaml(dataset, tmp_path, capsys):
    ds, rig = dataset
    full = ff.opencv_file(rig, tmp_path / "opencv.yml", extra={"E": rig.essential(), "F": rig.fundamental()})
    bare = ff.opencv_file(rig, tmp_path / "bare.xml", rectification=False)
    assert main(["stereo-import", str(full), "--out", str(tmp_path / "stereo.yaml")]) == 0
    assert "unknown" in capsys.readouterr().out
    for pose in (0, 1):
        ours = _locate(ds, tmp_path / "stereo.yaml", pose, capsys)
        for theirs in (full, bare):
            np.testing.assert_allclose(_locate(ds, theirs, pose, capsys), ours, rtol=0, atol=1e-9)


@pytest.mark.parametrize("make", ["opencv", "stereo_calib", "ros", "kalibr", "matlab", "matlab_mat"])
def test_stereo_import_of_each_format(dataset, tmp_path, capsys, make):
    _, rig = dataset
    sources = {"opencv": lambda: [ff.opencv_file(rig, tmp_path / "s.yml")],
               "stereo_calib": lambda: list(ff.stereo_calib_pair(rig, tmp_path)),
               "ros": lambda: list(ff.ros_pair(rig, tmp_path)),
               "kalibr": lambda: [ff.kalibr_camchain(rig, tmp_path / "camchain.yaml")],
               "matlab": lambda: [ff.matlab_json(rig, tmp_path / "stereoParams.json")],
               "matlab_mat": lambda: [ff.matlab_mat(rig, tmp_path / "stereo.mat")]}[make]()
    out = tmp_path / "out" / "stereo.yaml"
    code = main(["stereo-import", *map(str, sources), "--out", str(out), "--json",
                 "--image-size", f"{rig.left.size[0]}x{rig.left.size[1]}"])
    captured = capsys.readouterr()
    assert code == 0, captured.err
    data = json.loads(captured.out)
    assert data["stereo"]["rms_stereo"] is None and data["stereo"]["board_cols"] is None
    sf = read_stereo_yaml(out)
    X = np.column_stack([np.linspace(-250, 250, 30), np.linspace(-150, 200, 30), np.linspace(600, 1500, 30)])
    for got, want in zip(sf.rig.project(X), rig.project(X)):
        assert np.abs(got - want).max() <= 1e-6


def test_matlab_mat_file_locates_like_the_opencv_file(dataset, tmp_path, capsys):
    """`robocal locate --stereo stereo.mat` (MATLAB's toStruct saved with save): the marker at
    the same place as with the OpenCV file of the same cameras, and as with its converted stereo.yaml."""
    ds, rig = dataset
    mat = ff.matlab_mat(rig, tmp_path / "stereo.mat", intrinsics="K", pose="PoseCamera2", units="meters")
    bare = ff.opencv_file(rig, tmp_path / "bare.yml", rectification=False)
    assert main(["stereo-import", str(mat), "--out", str(tmp_path / "stereo.yaml")]) == 0
    assert "MATLAB stereoParameters (MAT)" in capsys.readouterr().out
    for pose in (0, 1):
        theirs = _locate(ds, mat, pose, capsys)
        np.testing.assert_array_equal(_locate(ds, tmp_path / "stereo.yaml", pose, capsys), theirs)
        np.testing.assert_allclose(_locate(ds, bare, pose, capsys), theirs, rtol=0, atol=1e-6)


def test_stereo_import_refusals(dataset, tmp_path, capsys):
    _, rig = dataset
    intrinsics, extrinsics = ff.stereo_calib_pair(rig, tmp_path)
    assert main(["stereo-import", str(intrinsics), "--out", str(extrinsics)]) == 2       # the file found beside
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "same file as the input" in err[0] and "extrinsics.yml" in err[0]
    chain = ff.kalibr_camchain(rig, tmp_path / "camchain.yaml", model="equidistant")
    before = extrinsics.read_bytes()
    assert main(["stereo-import", str(chain), "--out", str(tmp_path / "new.yaml")]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "camchain.yaml: field 'cam0.distortion_model'" in err[0]
    assert not (tmp_path / "new.yaml").exists() and extrinsics.read_bytes() == before
    assert main(["stereo-import", str(intrinsics), "--out", str(tmp_path / "x.yaml"), "--image-size", "big"]) == 2
    assert "--image-size" in capsys.readouterr().err
    v73 = tmp_path / "v73.mat"                        # the header of a MAT-file 7.3 (HDF5)
    v73.write_bytes(b"MATLAB 7.3 MAT-file".ljust(116, b" ") + bytes(8) + b"\x00\x02IM" + bytes(384)
                    + b"\x89HDF\r\n\x1a\n")
    assert main(["stereo-import", str(v73), "--out", str(tmp_path / "new.yaml")]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "v73.mat: a MAT-file version 7.3 (HDF5)" in err[0] and "'-v7'" in err[0]
    assert not (tmp_path / "new.yaml").exists()


def test_stereo_import_help_names_the_matlab_mat_file(capsys):
    assert main(["stereo-import", "--help"]) == 0
    text = " ".join(capsys.readouterr().out.split())
    assert "MATLAB stereoParameters .json or .mat" in text and "'-v7'" in text


def test_select_poses_takes_an_opencv_file(tmp_path, capsys):
    """select-poses --stereo gives the same poses with an OpenCV file as with its stereo.yaml."""
    from core.robot.file import write_robot
    from core.virtual_lab.lab import VirtualLab

    lab = VirtualLab.create(seed=0)
    robot = write_robot(lab.nominal_robot, tmp_path / "robot.json")      # placed in the left camera frame
    cv_file = ff.opencv_file(lab.rig, tmp_path / "stereo.yml")
    assert main(["stereo-import", str(cv_file), "--out", str(tmp_path / "stereo.yaml")]) == 0
    outputs = []
    for stereo in (cv_file, tmp_path / "stereo.yaml"):
        out = tmp_path / f"poses_{stereo.suffix[1:]}.csv"
        code = main(["select-poses", "--robot", str(robot), "--stereo", str(stereo), "--count", "12",
                     "--candidates", "300", "--random-trials", "1", "--plate", "60", "--out", str(out)])
        captured = capsys.readouterr()
        assert code == 0, captured.err
        outputs.append(out.read_text())
    assert outputs[0] == outputs[1] and len(outputs[0].splitlines()) > 12
