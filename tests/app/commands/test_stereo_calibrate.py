"""`robocal stereo-calibrate` on real pairs copied into a temporary folder, and every kind of
bad input: one clear line, exit code 1 (2 for misuse), and a previous stereo.yaml untouched."""
from __future__ import annotations

import json
import shutil
from pathlib import Path

import cv2
import pytest

from app.cli import main
from core.stereo.file import read_stereo_yaml
from tests.core.stereo_synth import REAL_DATA, REAL_REFERENCE_FOCAL, real_pairs

pytestmark = pytest.mark.skipif(not REAL_DATA.is_dir(), reason=f"real checkerboard pairs not found at {REAL_DATA}")

NUMBERS = [1, 3, 5, 8, 11, 13, 17, 19, 22, 24]       # 10 well spread real pairs


def _copy(tmp_path: Path, numbers=NUMBERS) -> tuple[Path, Path]:
    left, right = tmp_path / "left", tmp_path / "right"
    left.mkdir(exist_ok=True)
    right.mkdir(exist_ok=True)
    for a, b in real_pairs(numbers):
        shutil.copy(a, left / a.name)
        shutil.copy(b, right / b.name)
    return left, right


def _run(capsys, *args):
    code = main(["stereo-calibrate", *map(str, args)])
    out = capsys.readouterr()
    return code, out.out, out.err


def _args(left, right, out, *more):
    return ["--left", left, "--right", right, "--board", "9x6", "--square", "24", "--out", out, *more]


def test_json_on_real_pairs(tmp_path, capsys):
    left, right = _copy(tmp_path)
    out = tmp_path / "stereo.yaml"
    code, stdout, err = _run(capsys, *_args(left, right, out, "--json", "--ros", tmp_path / "ros",
                                            "--export-json", tmp_path / "full.json"))
    assert code == 0, err
    assert err == ""
    data = json.loads(stdout)
    for key in ("rms_left", "rms_right", "rms_stereo", "epipolar_rms", "baseline_mm", "pairs_used",
                "pairs_rejected", "cross_validation_px"):
        assert key in data, key
    for side in ("left", "right"):
        assert set(data[side]) == {"fx", "fy", "cx", "cy"}
        assert abs(data[side]["fx"] / REAL_REFERENCE_FOCAL - 1) < 0.02
    assert data["pairs_used"] == 10 and data["pairs_rejected"] == []
    assert data["rms_stereo"] < 0.3 and data["cross_validation_px"] > 0
    sf = read_stereo_yaml(out)
    assert sf.image_size == (640, 512) and sf.board.square == 24.0
    fs = cv2.FileStorage(str(out), cv2.FILE_STORAGE_READ)
    assert fs.getNode("P2").mat().shape == (3, 4)
    fs.release()
    assert (tmp_path / "ros" / "left.yaml").is_file() and (tmp_path / "ros" / "right.yaml").is_file()
    assert json.loads((tmp_path / "full.json").read_text())["calibration"]["pairs_used"] == 10


def test_one_folder_of_left_and_right_images(tmp_path, capsys):
    """--pairs DIR: the real pairs as they are published, leftNN and rightNN in one folder."""
    folder = tmp_path / "pairs"
    folder.mkdir()
    for a, b in real_pairs(NUMBERS):
        shutil.copy(a, folder / a.name)
        shutil.copy(b, folder / b.name)
    (folder / "README.md").write_text("pairs")
    out = tmp_path / "stereo.yaml"
    code, stdout, err = _run(capsys, "--pairs", folder, "--board", "9x6", "--square", "24", "--out", out, "--json")
    assert code == 0, err
    data = json.loads(stdout)
    assert data["pairs_used"] == 10 and data["ignored_files"] == [f"{folder}: README.md"]
    left, right = _copy(tmp_path)
    code, stdout, err = _run(capsys, *_args(left, right, tmp_path / "split.yaml", "--json"))
    assert code == 0, err
    assert json.loads(stdout)["rms_stereo"] == pytest.approx(data["rms_stereo"], rel=1e-9)


def test_text_output_patterns_and_exclude(tmp_path, capsys):
    out = tmp_path / "s.yaml"
    pattern_l = str(REAL_DATA / "left0*.jpg")       # 9 pairs from the shared folder itself
    pattern_r = str(REAL_DATA / "right0*.jpg")
    code, stdout, err = _run(capsys, *_args(pattern_l, pattern_r, out, "--exclude", "2,left05.jpg",
                                            "--radial", "2", "--fix-aspect"))
    assert code == 0, err
    assert "7 pairs used" in stdout and "excluded pair 2" in stdout and "excluded pair 5" in stdout
    assert "reprojection RMS" in stdout and f"wrote {out}" in stdout
    sf = read_stereo_yaml(out)
    assert sf.K1[0, 0] == sf.K1[1, 1] and sf.D1[4] == 0


def test_bad_files_are_skipped_with_reasons(tmp_path, capsys):
    left, right = _copy(tmp_path)
    (left / "notes.txt").write_text("not an image")
    (left / "left90.jpg").write_bytes(b"garbage, not a jpeg")
    (right / "right90.jpg").write_bytes((REAL_DATA / "right02.jpg").read_bytes())
    data = (REAL_DATA / "left02.jpg").read_bytes()
    (left / "left91.jpg").write_bytes(data[: len(data) // 3])
    (right / "right91.jpg").write_bytes((REAL_DATA / "right02.jpg").read_bytes())
    big = cv2.resize(cv2.imread(str(REAL_DATA / "right04.jpg")), (800, 640))
    (left / "left92.jpg").write_bytes((REAL_DATA / "left04.jpg").read_bytes())
    cv2.imwrite(str(right / "right92.jpg"), big)
    code, stdout, err = _run(capsys, *_args(left, right, tmp_path / "s.yaml", "--json"))
    assert code == 0, err
    data = json.loads(stdout)
    reasons = {r["files"]: r["reason"] for r in data["pairs_rejected"]}
    assert "not a readable image" in reasons["left90.jpg | right90.jpg"]
    assert "truncated JPEG" in reasons["left91.jpg | right91.jpg"]
    assert "size mismatch" in reasons["left92.jpg | right92.jpg"]
    assert data["pairs_used"] == 10
    assert any("notes.txt" in name for name in data["ignored_files"])


def _assert_failed(code, stdout, err, *words):
    assert code == 1, err
    assert stdout == ""
    assert err.count("\n") == 1 and err.startswith("robocal stereo-calibrate: ")
    assert "Traceback" not in err
    for w in words:
        assert w in err, (w, err)


@pytest.fixture
def previous(tmp_path):
    """A previous good stereo.yaml that failed runs must leave as it is."""
    path = tmp_path / "stereo.yaml"
    path.write_text("%YAML:1.0\n---\nprevious: good\n")
    return path


def test_unequal_counts(tmp_path, capsys, previous):
    left, right = _copy(tmp_path, [1, 2, 3])
    (right / "right03.jpg").unlink()
    code, stdout, err = _run(capsys, *_args(left, right, previous))
    _assert_failed(code, stdout, err, "3 left images", "2 right images", "left03.jpg")
    assert previous.read_text().endswith("previous: good\n")


def test_wrong_board_size(tmp_path, capsys, previous):
    left, right = _copy(tmp_path, [1, 2, 3, 4, 5, 6])
    code, stdout, err = _run(capsys, "--left", left, "--right", right, "--board", "8x6", "--square", "24",
                             "--out", previous)
    _assert_failed(code, stdout, err, "no usable pair", "9x6", "board size", "left01.jpg")
    assert previous.read_text().endswith("previous: good\n")


def test_too_few_usable_pairs(tmp_path, capsys, previous):
    left, right = _copy(tmp_path, [1, 2, 3])
    code, stdout, err = _run(capsys, *_args(left, right, previous))
    _assert_failed(code, stdout, err, "only 3 usable pairs of 3", "at least 6")
    assert previous.read_text().endswith("previous: good\n")


def test_all_pairs_rejected(tmp_path, capsys, previous):
    left, right = tmp_path / "L", tmp_path / "R"
    left.mkdir()
    right.mkdir()
    for n in range(3):
        (left / f"l{n}.png").write_bytes(b"\x89PNG\r\n\x1a\n truncated")
        cv2.imwrite(str(right / f"r{n}.png"), cv2.imread(str(REAL_DATA / "right01.jpg"))[:, :, 0] * 0 + 128)
    code, stdout, err = _run(capsys, *_args(left, right, previous))
    _assert_failed(code, stdout, err, "no usable pair among the 3 pairs", "truncated PNG", "l0.png",
                   "board not found", "r2.png")
    assert previous.read_text().endswith("previous: good\n")


def test_missing_folder_and_no_images(tmp_path, capsys, previous):
    empty = tmp_path / "empty"
    empty.mkdir()
    code, stdout, err = _run(capsys, *_args(tmp_path / "nope", empty, previous))
    _assert_failed(code, stdout, err, "nope", "no such folder")
    code, stdout, err = _run(capsys, *_args(empty, empty, previous))
    _assert_failed(code, stdout, err, "same folder")
    other = tmp_path / "other"
    other.mkdir()
    code, stdout, err = _run(capsys, *_args(empty, other, previous))
    _assert_failed(code, stdout, err, "no image files")


def test_no_images_given_is_a_usage_error(tmp_path, capsys):
    code, stdout, err = _run(capsys, "--left", tmp_path, "--board", "9x6", "--square", "24")
    assert code == 2 and stdout == "" and "--pairs DIR for one folder of leftNN/rightNN images" in err


def test_unwritable_output_refused_before_the_work(tmp_path, capsys):
    left, right = _copy(tmp_path, [1, 2])
    blocker = tmp_path / "a-file"
    blocker.write_text("not a folder")
    code, stdout, err = _run(capsys, *_args(left, right, blocker / "stereo.yaml"))
    _assert_failed(code, stdout, err, "a-file is a file, not a folder")


@pytest.mark.parametrize("extra, words", [
    (["--board", "9by6"], ["board size must look like 9x6"]),
    (["--square", "-3"], ["argument --square: -3 mm is outside 0.001 … 10000 mm"]),
    (["--radial", "4"], ["invalid choice"]),
    (["--exclude", "99"], ["pair 99 does not exist"]),
    (["--pairs", "."], ["either --pairs DIR or --left and --right"]),
])
def test_usage_errors_exit_2(tmp_path, capsys, extra, words):
    left, right = _copy(tmp_path, [1, 2])
    args = _args(left, right, tmp_path / "s.yaml")
    for flag, value in zip(extra[::2], extra[1::2]):
        if flag in args:
            args[args.index(flag) + 1] = value
        else:
            args += [flag, value]
    code, stdout, err = _run(capsys, *args)
    assert code == 2 and stdout == ""
    for w in words:
        assert w in err
    assert not (tmp_path / "s.yaml").exists()


@pytest.fixture
def previous_outputs(tmp_path):
    """stereo.yaml, the ROS files and the JSON export of an earlier run: a failed run leaves all four."""
    files = {tmp_path / "stereo.yaml": b"%YAML:1.0\n---\nprevious: good\n",
             tmp_path / "ros" / "left.yaml": b"previous left\n", tmp_path / "ros" / "right.yaml": b"previous right\n",
             tmp_path / "full.json": b'{"previous": true}\n'}
    for path, data in files.items():
        path.parent.mkdir(exist_ok=True)
        path.write_bytes(data)
    return files


def _outputs_args(left, right, tmp_path):
    return _args(left, right, tmp_path / "stereo.yaml", "--ros", tmp_path / "ros", "--export-json",
                 tmp_path / "full.json")


def _unchanged(tmp_path, files):
    assert {p: p.read_bytes() for p in files if p.is_file()} == {p: d for p, d in files.items() if p.is_file()}
    left_over = [p.name for p in tmp_path.rglob(".*") if p.is_file()]
    assert left_over == [], left_over


def test_a_folder_in_the_way_of_a_ros_file_changes_no_output(tmp_path, capsys, previous_outputs):
    left, right = _copy(tmp_path, NUMBERS[:6])
    right_yaml = tmp_path / "ros" / "right.yaml"
    right_yaml.unlink()
    right_yaml.mkdir()
    del previous_outputs[right_yaml]
    code, stdout, err = _run(capsys, *_outputs_args(left, right, tmp_path))
    _assert_failed(code, stdout, err, str(right_yaml), "a folder is in the way")
    _unchanged(tmp_path, previous_outputs)


def test_a_write_that_fails_on_the_last_output_changes_no_output(tmp_path, previous_outputs):
    """A real failure after the calibration: the JSON export (about 12 kB) exceeds the process's file
    size limit (RLIMIT_FSIZE, 8 kB) while stereo.yaml and the ROS files (3 kB, 1 kB) fit."""
    import resource
    import signal
    import subprocess
    import sys

    def limit():
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
        resource.setrlimit(resource.RLIMIT_FSIZE, (8000, 8000))

    left, right = _copy(tmp_path, NUMBERS[:6])
    argv = [sys.executable, "-m", "app.cli", "stereo-calibrate", *map(str, _outputs_args(left, right, tmp_path))]
    root = Path(__file__).resolve().parents[3]
    proc = subprocess.run(argv, capture_output=True, text=True, timeout=120, preexec_fn=limit, cwd=tmp_path,
                          env={"PATH": "/usr/bin:/bin", "PYTHONPATH": str(root), "PYTHONDONTWRITEBYTECODE": "1",
                               "HOME": str(tmp_path)})
    _assert_failed(proc.returncode, proc.stdout, proc.stderr, "full.json", "File too large",
                   "no output was changed")
    _unchanged(tmp_path, previous_outputs)
