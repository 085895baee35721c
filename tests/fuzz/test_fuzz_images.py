"""Fuzzing the commands that read images: `stereo-calibrate`, `locate` and `measure` with
truncated, empty, mislabelled, tiny, 16-bit and absurdly sized images, and with bytes cut or
flipped at random (hypothesis, derandomised).

A bad image is never a traceback or an "internal error": `locate` ends with exit 1 and one line
naming the image; `stereo-calibrate` and `measure` skip the pair or pose with a reason that
names the file (exit 0 when enough is left, else exit 1 and one line); no file is created or
changed by a failed run. An image that is still decodable after the mutation may succeed.
"""
from __future__ import annotations

import shutil
import struct
import zlib

import cv2
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from tests.core.stereo_synth import REAL_DATA
from tests.fuzz.test_fuzz_commands import assert_one_clear_line, run

FUZZ = settings(derandomize=True, max_examples=15, deadline=None, database=None,
                suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])


def _png_chunk(kind: bytes, data: bytes) -> bytes:
    return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)


def png_header_only(width: int, height: int, depth: int = 8, colour: int = 0) -> bytes:
    """A PNG whose header (with valid checksums) declares width x height, with one row of data."""
    row = b"\x00" + b"\x80" * min(width, 4096)
    return (b"\x89PNG\r\n\x1a\n" + _png_chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, depth, colour, 0, 0, 0))
            + _png_chunk(b"IDAT", zlib.compress(row)) + _png_chunk(b"IEND", b""))


def _encode(image: np.ndarray, ext: str) -> bytes:
    ok, buf = cv2.imencode(ext, image)
    assert ok
    return buf.tobytes()


def image_cases(gray: np.ndarray) -> dict[str, tuple[str, bytes]]:
    """name -> (file suffix, bytes): the hand-made table, from one valid 8-bit image."""
    png, jpg = _encode(gray, ".png"), _encode(gray, ".jpg")
    return {
        "empty file": (".png", b""),
        "truncated PNG": (".png", png[:len(png) // 2]),
        "PNG cut in its header": (".png", png[:30]),
        "truncated JPEG": (".jpg", jpg[:len(jpg) // 2]),
        "JPEG named .png": (".png", jpg),
        "text named .png": (".png", b"this is not an image\n"),
        "1x1 image": (".png", _encode(np.zeros((1, 1), np.uint8), ".png")),
        "16-bit image": (".png", _encode(gray.astype(np.uint16) * 257, ".png")),
        "header says 60000x60000": (".png", png_header_only(60000, 60000)),
        "header says 30000x30000 RGB 16-bit": (".png", png_header_only(30000, 30000, depth=16, colour=2)),
        "header says 0x0": (".png", png_header_only(0, 0)),
        "JPEG with its middle zeroed": (".jpg", jpg[:600] + bytes(len(jpg) // 2) + jpg[600 + len(jpg) // 2:]),
    }


MUTATION = st.one_of(
    st.tuples(st.just("cut"), st.floats(0.0, 1.0)),
    st.tuples(st.just("flip"), st.lists(st.tuples(st.floats(0.0, 1.0), st.integers(0, 255)), min_size=1,
                                        max_size=6)),
)


def mutated(data: bytes, mutation) -> bytes:
    kind, arg = mutation
    if kind == "cut":
        return data[:int(arg * len(data))]
    out = bytearray(data)
    for where, value in arg:
        out[min(int(where * len(out)), len(out) - 1)] = value
    return bytes(out)


# -- stereo-calibrate -------------------------------------------------------------------------------

@pytest.fixture(scope="module")
def boards(tmp_path_factory):
    if not REAL_DATA.is_dir():
        pytest.skip(f"real checkerboard pairs not found at {REAL_DATA}")
    folder = tmp_path_factory.mktemp("boards")
    gray = cv2.imread(str(REAL_DATA / "left01.jpg"), cv2.IMREAD_GRAYSCALE)
    return folder, gray


def stereo_calibrate(boards, tmp_path, name: str, data: bytes, suffix: str):
    """Two real pairs, the first left image replaced by `data`: exit 1 (too few pairs), one line."""
    left, right = tmp_path / "left", tmp_path / "right"
    left.mkdir()
    right.mkdir()
    for n in (1, 2):
        shutil.copy(REAL_DATA / f"right0{n}.jpg", right / f"r{n}.jpg")
    shutil.copy(REAL_DATA / "left02.jpg", left / "l2.jpg")
    bad = left / f"l1{suffix}"
    bad.write_bytes(data)
    code, err = run(["stereo-calibrate", "--left", str(left), "--right", str(right), "--board", "9x6",
                     "--square", "24", "--out", str(tmp_path / "stereo.yaml")], tmp_path)
    assert_one_clear_line(code, err, [str(left), bad.name, "usable pair"])
    assert not (tmp_path / "stereo.yaml").exists()
    return err[0]


@pytest.mark.parametrize("name", list(image_cases(np.zeros((8, 8), np.uint8))))
def test_stereo_calibrate_hand_made_images(boards, tmp_path, name):
    suffix, data = image_cases(boards[1])[name]
    stereo_calibrate(boards, tmp_path, name, data, suffix)


@FUZZ
@given(mutation=MUTATION, kind=st.sampled_from([".png", ".jpg"]))
def test_stereo_calibrate_mutated_images(boards, tmp_path_factory, mutation, kind):
    data = mutated(_encode(boards[1], kind), mutation)
    stereo_calibrate(boards, tmp_path_factory.mktemp("sc"), "mutated", data, kind)


# -- locate and measure -----------------------------------------------------------------------------

@pytest.fixture(scope="module")
def poses(tmp_path_factory):
    """A two-pose marker dataset with its true stereo.yaml and a trained marker file."""
    from core.images import load_gray
    from core.marker.training import train_marker
    from tests.app.virtual_inputs import marker_dataset

    ds = marker_dataset(tmp_path_factory.mktemp("poses"), poses=2)
    train_marker(load_gray(ds / "marker" / "training.png")[0]).save(ds / "marker.npz")
    gray = cv2.imread(str(ds / "poses" / "left" / "pose_000.png"), cv2.IMREAD_GRAYSCALE)
    return ds, gray


def locate(poses, tmp_path, data: bytes, suffix: str):
    ds, _ = poses
    bad = tmp_path / f"left{suffix}"
    bad.write_bytes(data)
    code, err = run(["locate", "--stereo", str(ds / "stereo.yaml"), "--marker", str(ds / "marker.npz"),
                     "--left", str(bad), "--right", str(ds / "poses" / "right" / "pose_000.png")], tmp_path)
    if code != 0:
        assert_one_clear_line(code, err, [str(bad)])
    else:
        assert err == []


@pytest.mark.parametrize("name", list(image_cases(np.zeros((8, 8), np.uint8))))
def test_locate_hand_made_images(poses, tmp_path, name):
    suffix, data = image_cases(poses[1])[name]
    locate(poses, tmp_path, data, suffix)


@FUZZ
@given(mutation=MUTATION)
def test_locate_mutated_images(poses, tmp_path_factory, mutation):
    data = mutated(_encode(poses[1], ".png"), mutation)
    locate(poses, tmp_path_factory.mktemp("loc"), data, ".png")


@pytest.mark.parametrize("name", ["empty file", "truncated PNG", "text named .png", "1x1 image",
                                  "header says 60000x60000", "header says 30000x30000 RGB 16-bit"])
def test_measure_with_a_bad_pose_image(poses, tmp_path, name):
    """The bad image's pose is rejected with a reason naming the image; the other is measured."""
    from core.measurement.run import read_rejects

    ds, gray = poses
    images = tmp_path / "poses"
    shutil.copytree(ds / "poses", images)
    suffix, data = image_cases(gray)[name]
    (images / "left" / "pose_000.png").write_bytes(data)
    out = tmp_path / "m.csv"
    code, err = run(["measure", "--stereo", str(ds / "stereo.yaml"), "--marker", str(ds / "marker.npz"),
                     "--images", str(images), "--joints", str(images / "joints.csv"), "--out", str(out)], tmp_path)
    assert code == 0 and err == [], err
    rejects = read_rejects(out.with_name("m.rejects.csv"))
    assert list(rejects) == [0] and "pose_000.png" in rejects[0][2], rejects
