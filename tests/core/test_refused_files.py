"""A refused file is never modified, and nothing is written onto what is not a regular file.

Every append path (the check log, the measurements file and its rejects file when a run is
resumed) reads and checks the existing file before it repairs a cut-off last row, so a file of
another kind (a PNG, a CSV of another tool, a log of another robot) comes back byte for byte.
Every atomic writer refuses an output that is a folder, a device or a pipe instead of renaming
a regular file over it.
"""
from __future__ import annotations

import hashlib
import os
import re

import cv2
import numpy as np
import pytest

import core.files as files
from core.errors import RoboCalError
from core.measurement.file import MeasurementWriter
from core.measurement.run import RejectsWriter, rejects_path_for, run_measurements
from core.monitoring.log import CheckLogWriter

from tests.core.measurement.test_run import fake_capture, fake_locate, pose_list


def png_bytes() -> bytes:
    ok, buf = cv2.imencode(".png", np.arange(64, dtype=np.uint8).reshape(8, 8))
    assert ok
    return buf.tobytes()


def digest(path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


# files of another kind, none ending with a newline (the case a repair would cut)
OTHER_FILES = {
    "png": png_bytes(),
    "binary": bytes(range(256)) * 3,
    "csv of another tool": b"time,x,y\n0.1,2,3\n0.2,4,5",
    "text": b"just some notes\nwithout a newline at the end",
}


@pytest.mark.parametrize("kind", OTHER_FILES)
def test_a_check_log_that_is_not_one_is_refused_unchanged(tmp_path, kind):
    log = tmp_path / "checks.csv"
    log.write_bytes(OTHER_FILES[kind])
    before = digest(log)
    with pytest.raises(RoboCalError) as info:
        CheckLogWriter(log, 6)
    assert str(log) in str(info.value)
    assert digest(log) == before


def test_a_check_log_of_another_robot_with_a_cut_row_is_refused_unchanged(tmp_path):
    log = tmp_path / "checks.csv"
    with CheckLogWriter(log, 5) as w:
        w.overall("r1", "2025-01-01T00:00:00+00:00", 0.3, 0.5, True)
    with open(log, "ab") as handle:
        handle.write(b"r2,2025-01-01T00:01:00+00:00,point,0,mar")          # a killed run's last row
    before = digest(log)
    with pytest.raises(RoboCalError, match="5 joints, not 6"):
        CheckLogWriter(log, 6)
    assert digest(log) == before
    with CheckLogWriter(log, 5):                                            # its own robot: repaired
        pass
    assert log.read_bytes().endswith(b"1,,,,,,,\n") and b"mar" not in log.read_bytes()     # its overall row, whole


@pytest.mark.parametrize("kind", OTHER_FILES)
def test_a_measurements_file_that_is_not_one_is_refused_unchanged(tmp_path, kind):
    out = tmp_path / "meas.csv"
    out.write_bytes(OTHER_FILES[kind])
    before = digest(out)
    with pytest.raises(RoboCalError):
        MeasurementWriter(out, 6)
    assert digest(out) == before
    with pytest.raises(RoboCalError):
        run_measurements(pose_list(3), out, locate=fake_locate, capture=fake_capture, resume=True)
    assert digest(out) == before


def test_a_measurements_file_of_other_columns_with_a_cut_row_is_refused_unchanged(tmp_path):
    out = tmp_path / "meas.csv"
    with MeasurementWriter(out, 5) as w:
        w.append(0, "marker", [1, 2, 3, 4, 5], [10, 20, 30])
    with open(out, "ab") as handle:
        handle.write(b"1,marker,1,2")
    before = digest(out)
    with pytest.raises(RoboCalError, match="columns"):
        MeasurementWriter(out, 6)
    assert digest(out) == before


@pytest.mark.parametrize("kind", OTHER_FILES)
def test_a_rejects_file_that_is_not_one_is_refused_unchanged(tmp_path, kind):
    out = tmp_path / "meas.csv"
    rejects = rejects_path_for(out)
    rejects.write_bytes(OTHER_FILES[kind])
    before = digest(rejects)
    with pytest.raises(RoboCalError):
        RejectsWriter(rejects, 6)
    assert digest(rejects) == before
    with pytest.raises(RoboCalError):
        run_measurements(pose_list(4), out, locate=fake_locate, capture=fake_capture, resume=True)
    assert digest(rejects) == before


def test_a_rejects_file_with_a_cut_row_is_repaired_when_it_is_appended_to(tmp_path):
    rejects = tmp_path / "meas.rejects.csv"
    with RejectsWriter(rejects, 2) as w:
        w.append(3, "marker", [1, 2], "no marker found")
    with open(rejects, "ab") as handle:
        handle.write(b"4,mark")
    with RejectsWriter(rejects, 2) as w:
        w.append(5, "marker", [1, 2], "blurred")
    rows = rejects.read_text().splitlines()
    assert rows[-2].startswith("3,marker") and rows[-1].startswith("5,marker") and "4,mark" not in rejects.read_text()


def special_paths(tmp_path):
    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)
    folder = tmp_path / "folder"
    folder.mkdir()
    return {"a pipe (FIFO)": fifo, "a folder": folder, "a device": os.devnull}


def test_atomic_writers_refuse_what_is_not_a_regular_file(tmp_path):
    for kind, path in special_paths(tmp_path).items():
        with pytest.raises(RoboCalError, match=re.escape(f"this is {kind}, not a regular file")) as info:
            files.atomic_write_bytes(path, b"data")
        assert str(path) in str(info.value)
        with pytest.raises(RoboCalError):
            files.atomic_write_many({tmp_path / "first.json": "{}", path: "{}"})
        assert not (tmp_path / "first.json").exists()
    assert os.path.exists(os.devnull) and not os.path.isfile(os.devnull)
    assert (tmp_path / "pipe").is_fifo() and (tmp_path / "folder").is_dir()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["folder", "pipe"]       # no temporary left


def test_append_writers_refuse_what_is_not_a_regular_file_without_blocking(tmp_path):
    for kind, path in special_paths(tmp_path).items():
        for make in (lambda p: CheckLogWriter(p, 6), lambda p: MeasurementWriter(p, 6),
                     lambda p: RejectsWriter(p, 6), files.drop_partial_last_line):
            with pytest.raises(RoboCalError, match=re.escape(f"this is {kind}, not a regular file")):
                make(path)
