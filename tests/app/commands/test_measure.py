"""`robocal measure` end to end on a small `robocal simulate` dataset with the true stereo parameters:
the measurements written, resumed, overwritten and kept after a failed run; bad inputs."""
from __future__ import annotations

import json
import shutil

import numpy as np

from app.cli import main


def test_measure_writes_the_measurements_and_resumes(pose_dataset, tmp_path, capsys):
    from core.measurement.file import read_measurements

    ds, truth = pose_dataset
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


def test_measure_bad_inputs(pose_dataset, tmp_path, capsys):
    ds, _ = pose_dataset
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
