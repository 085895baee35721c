"""`robocal locate` on a small `robocal simulate` dataset with the true stereo parameters (the
calibration step is tested elsewhere): x y z, --json, a trained marker file, bad inputs."""
from __future__ import annotations

import json

import numpy as np
import pytest

from app.cli import main


def _locate_args(ds, pose=0, *extra):
    return ["locate", "--stereo", str(ds / "stereo.yaml"), "--marker", str(ds / "marker" / "training.png"),
            "--left", str(ds / "poses" / "left" / f"pose_{pose:03d}.png"),
            "--right", str(ds / "poses" / "right" / f"pose_{pose:03d}.png"), *extra]


def test_locate_prints_x_y_z(pose_dataset, capsys):
    ds, truth = pose_dataset
    code = main(_locate_args(ds, 0))
    captured = capsys.readouterr()
    assert code == 0, captured.err
    xyz = [float(v) for v in captured.out.split()]
    assert len(xyz) == 3
    assert np.linalg.norm(np.array(xyz) - truth["poses"][0]["marker"]) < 0.15
    assert captured.err == ""


def test_locate_json(pose_dataset, capsys):
    ds, truth = pose_dataset
    code = main(_locate_args(ds, 1, "--json"))
    captured = capsys.readouterr()
    assert code == 0, captured.err
    d = json.loads(captured.out)
    assert np.linalg.norm(np.array([d["x"], d["y"], d["z"]]) - truth["poses"][1]["marker"]) < 0.15
    for side in ("left", "right"):
        assert len(d[side]["image_point"]) == 2 and len(d[side]["rectified"]) == 2
    assert d["disparity"] > 0 and d["criteria_minimum"] >= 0 and 0 <= d["reliability"] < 0.6
    assert len(d["sigma"]) == 3 and d["sigma_px"] > 0
    assert d["marker_size_known"] is False and d["marker_size_mm"] == 40.0


def test_locate_with_a_trained_marker_file_and_size(pose_dataset, tmp_path, capsys):
    from core.marker.training import train_marker
    from core.images import load_gray

    ds, truth = pose_dataset
    npz = train_marker(load_gray(ds / "marker" / "training.png")[0]).save(tmp_path / "m.npz")
    args = _locate_args(ds, 2, "--json")
    args[args.index("--marker") + 1] = str(npz)
    assert main(args + ["--marker-size", "40"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["marker_size_known"] is True and d["size_mm"] == pytest.approx(40.0, abs=0.1)


def test_locate_bad_inputs_one_line_each(pose_dataset, tmp_path, capsys):
    ds, _ = pose_dataset
    # no marker in view: the left image of another pose pasted as a plain room image
    import cv2
    blank = tmp_path / "blank.png"
    cv2.imwrite(str(blank), np.full((1024, 1280), 128, np.uint8))
    args = _locate_args(ds, 0)
    args[args.index("--left") + 1] = str(blank)
    assert main(args) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "marker not located: left image: no marker found" in err[0]
    # a marker image without texture
    plain = tmp_path / "plain.png"
    from core.virtual_lab.marker_comparison import plain_pattern
    cv2.imwrite(str(plain), plain_pattern())
    args = _locate_args(ds, 0)
    args[args.index("--marker") + 1] = str(plain)
    assert main(args) == 1
    err = capsys.readouterr().err
    assert "SIFT features" in err and "texture" in err and "Traceback" not in err
    # missing files and usage errors
    args = _locate_args(ds, 0)
    args[args.index("--stereo") + 1] = str(tmp_path / "nope.yaml")
    assert main(args) == 1
    assert "nope.yaml" in capsys.readouterr().err
    assert main(_locate_args(ds, 0, "--marker-size", "-3")) == 2
    assert "--marker-size" in capsys.readouterr().err
    assert main(["locate", "--stereo", "x"]) == 2
    capsys.readouterr()
