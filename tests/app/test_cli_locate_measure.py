"""`robocal locate` and `robocal measure` end to end on a small `robocal simulate` dataset,
with the true stereo parameters (the calibration step is tested elsewhere)."""
from __future__ import annotations

import json
import shutil

import numpy as np
import pytest

from app.cli import main


@pytest.fixture(scope="session")
def dataset(tmp_path_factory):
    from core.stereo.board import Board
    from core.camera import CameraModel
    from core.stereo.rectification import StereoRectification
    from core.stereo.file import StereoFile, write_stereo_yaml
    from core.stereo.rig import StereoRig
    from core.virtual_lab.dataset import simulate_dataset

    root = tmp_path_factory.mktemp("marker_cli")
    out = root / "ds"
    simulate_dataset(out, seed=3, pairs=0, poses=6)
    truth = json.loads((out / "truth.json").read_text())
    s = truth["stereo"]
    size = (s["image_width"], s["image_height"])
    rig = StereoRig(CameraModel(s["K1"], s["D1"], *size), CameraModel(s["K2"], s["D2"], *size), s["R"], s["T"])
    rect = StereoRectification.from_rig(rig)
    b = truth["board"]
    write_stereo_yaml(out / "stereo.yaml", StereoFile(
        size, rig.left.K, rig.left.dist, rig.right.K, rig.right.dist, rig.R, rig.T, rig.essential(),
        rig.fundamental(), rect.R1, rect.R2, rect.P1, rect.P2, rect.Q, 0.0, 0.0, 0.0,
        Board(b["cols"], b["rows"], b["square"])))
    return out, truth


def _locate_args(ds, pose=0, *extra):
    return ["locate", "--stereo", str(ds / "stereo.yaml"), "--marker", str(ds / "marker" / "training.png"),
            "--left", str(ds / "poses" / "left" / f"pose_{pose:03d}.png"),
            "--right", str(ds / "poses" / "right" / f"pose_{pose:03d}.png"), *extra]


def test_locate_prints_x_y_z(dataset, capsys):
    ds, truth = dataset
    code = main(_locate_args(ds, 0))
    captured = capsys.readouterr()
    assert code == 0, captured.err
    xyz = [float(v) for v in captured.out.split()]
    assert len(xyz) == 3
    assert np.linalg.norm(np.array(xyz) - truth["poses"][0]["marker"]) < 0.15
    assert captured.err == ""


def test_locate_json(dataset, capsys):
    ds, truth = dataset
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


def test_locate_with_a_trained_marker_file_and_size(dataset, tmp_path, capsys):
    from core.marker.training import train_marker
    from core.images import load_gray

    ds, truth = dataset
    npz = train_marker(load_gray(ds / "marker" / "training.png")[0]).save(tmp_path / "m.npz")
    args = _locate_args(ds, 2, "--json")
    args[args.index("--marker") + 1] = str(npz)
    assert main(args + ["--marker-size", "40"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["marker_size_known"] is True and d["size_mm"] == pytest.approx(40.0, abs=0.1)


def test_locate_bad_inputs_one_line_each(dataset, tmp_path, capsys):
    ds, _ = dataset
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


def test_measure_writes_the_measurements_and_resumes(dataset, tmp_path, capsys):
    from core.measurement.file import read_measurements

    ds, truth = dataset
    images = tmp_path / "images"
    shutil.copytree(ds / "poses", images)
    # pose 4's right image shows no marker: rejected with a reason
    import cv2
    cv2.imwrite(str(images / "right" / "pose_004.png"), np.full((1024, 1280), 128, np.uint8))
    out = tmp_path / "meas.csv"
    args = ["measure", "--stereo", str(ds / "stereo.yaml"), "--marker", str(ds / "marker" / "training.png"),
            "--images", str(images), "--joints", str(images / "joints.csv"), "--out", str(out)]
    code = main(args)
    captured = capsys.readouterr()
    assert code == 0, captured.err
    assert "Measured 5 of 6 poses" in captured.out and "pose 4:" in captured.out
    meas = read_measurements(out)
    assert list(meas.pose) == [0, 1, 2, 3, 5] and set(meas.target) == {"marker"}
    for k, p in enumerate(meas.pose):
        # robot poses: the arm beside the plate; about 0.02 px per image (the bench's figures) at 650 mm
        assert np.linalg.norm(meas.xyz[k] - truth["poses"][p]["marker"]) < 0.15
        np.testing.assert_allclose(meas.q_file[k], truth["poses"][p]["q"], atol=1e-6)
    rejects = tmp_path / "meas.rejects.csv"
    assert "4,marker," in rejects.read_text()
    # an existing output is not overwritten silently
    assert main(args) == 1
    assert "--resume" in capsys.readouterr().err
    # resume: everything is done already
    assert main(args + ["--resume", "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["skipped"] == 6 and d["measured"] == 0
    # a failed --overwrite (cameras swapped: no pose measurable) keeps the earlier results byte for byte
    before = (out.read_bytes(), rejects.read_bytes())
    swapped = tmp_path / "swapped"
    shutil.copytree(images / "left", swapped / "right")
    shutil.copytree(images / "right", swapped / "left")
    wrong = args[:]
    wrong[wrong.index("--images") + 1] = str(swapped)
    assert main(wrong + ["--overwrite"]) == 1
    assert "none of the 6 poses could be measured" in capsys.readouterr().err
    assert (out.read_bytes(), rejects.read_bytes()) == before
    assert sorted(p.name for p in tmp_path.iterdir() if p.name.startswith(".meas")) == []
    # the rejected pose is measured again on request once its image is good
    shutil.copy(ds / "poses" / "right" / "pose_004.png", images / "right" / "pose_004.png")
    assert main(args + ["--resume", "--retry-rejected", "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["measured"] == 1 and d["skipped"] == 5
    assert list(read_measurements(out).pose) == [0, 1, 2, 3, 5, 4]
    # overwrite with the robot model: checked joint count, all 6 measured
    robot = tmp_path / "robot.json"
    robot.write_text(json.dumps(truth["nominal_robot"]))
    assert main(args + ["--overwrite", "--robot", str(robot), "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["measured"] == 6 and d["rejected"] == 0 and len(d["points"]) == 6
    assert not rejects.exists()


def test_measure_bad_inputs(dataset, tmp_path, capsys):
    ds, _ = dataset
    base = ["measure", "--stereo", str(ds / "stereo.yaml"), "--marker", str(ds / "marker" / "training.png"),
            "--images", str(ds / "poses"), "--out", str(tmp_path / "m.csv")]
    short = tmp_path / "joints.csv"
    short.write_text("\n".join((ds / "poses" / "joints.csv").read_text().splitlines()[:3]) + "\n")
    assert main(base + ["--joints", str(short)]) == 1
    err = capsys.readouterr().err
    assert "6 image pairs" in err and "2 poses" in err
    assert main(base + ["--joints", str(ds / "poses" / "joints.csv"), "--resume", "--overwrite"]) == 2
    capsys.readouterr()
    # no pose can be measured: wrong stereo file for these images (swapped cameras)
    (tmp_path / "imgs").mkdir()
    shutil.copytree(ds / "poses" / "left", tmp_path / "imgs" / "right")
    shutil.copytree(ds / "poses" / "right", tmp_path / "imgs" / "left")
    bad = base[:]
    bad[bad.index("--images") + 1] = str(tmp_path / "imgs")
    assert main(bad + ["--joints", str(ds / "poses" / "joints.csv")]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "none of the 6 poses could be measured" in err[0]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["imgs", "joints.csv"]     # nothing left behind
    assert main(bad + ["--joints", str(ds / "poses" / "joints.csv")]) == 1        # the same refusal again
    assert "none of the 6 poses" in capsys.readouterr().err
