"""core.files.atomic_write_many: all outputs written, or every one left as it was."""
from __future__ import annotations

import os

import pytest

import core.files as files
from core.errors import RoboCalError


def _state(folder):
    return {p.name: p.read_bytes() for p in sorted(folder.iterdir()) if p.is_file()}


def test_a_folder_in_the_way_is_refused_before_anything_is_written(tmp_path):
    a = tmp_path / "stereo.yaml"
    a.write_text("old")
    (tmp_path / "right.yaml").mkdir()
    with pytest.raises(RoboCalError, match="folder is in the way") as info:
        files.atomic_write_many({a: "new", tmp_path / "right.yaml": "new right"})
    assert "right.yaml" in str(info.value)
    assert _state(tmp_path) == {"stereo.yaml": b"old"}


@pytest.mark.parametrize("failing", [1, 2])
def test_a_failed_rename_puts_back_the_files_already_replaced(tmp_path, monkeypatch, failing):
    """The `failing`-th rename fails (an I/O error of the disk): the earlier ones are undone, a file
    that did not exist before is removed again, and no temporary is left."""
    a, b, c = tmp_path / "a.yaml", tmp_path / "b.yaml", tmp_path / "c.json"
    a.write_text("old a")
    c.write_text("old c")
    before = _state(tmp_path)
    real, calls = os.replace, []

    def replace(src, dst):
        calls.append(dst)
        if len(calls) == failing + 1:
            raise OSError(5, "Input/output error")
        return real(src, dst)

    monkeypatch.setattr(files.os, "replace", replace)
    with pytest.raises(RoboCalError, match="no output was changed"):
        files.atomic_write_many({a: "new a", b: "new b", c: "new c"})
    monkeypatch.setattr(files.os, "replace", real)
    assert _state(tmp_path) == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.yaml", "c.json"]


def test_every_file_is_replaced_and_no_copy_of_the_old_ones_is_left(tmp_path):
    a, b = tmp_path / "a.yaml", tmp_path / "sub" / "b.yaml"
    a.write_text("old a")
    assert files.atomic_write_many({a: "new a", b: b"new b"}) == [a, b]
    assert (a.read_text(), b.read_text()) == ("new a", "new b")
    assert sorted(p.name for p in tmp_path.rglob("*")) == ["a.yaml", "b.yaml", "sub"]
