"""One folder of both cameras' images (leftNN / rightNN) told apart by name."""
from __future__ import annotations

import pytest

from core.errors import RoboCalError
from core.stereo.image_files import pair_images
from core.stereo.image_pairs import camera_side, split_mixed_folder


@pytest.mark.parametrize("name, expected", [
    ("left01.jpg", ("left", "01")), ("RIGHT_07.PNG", ("right", "07")), ("pair03-right.png", ("right", "pair03")),
    ("img.12.Left.bmp", ("left", "img.12")), ("left.png", ("left", "")),
    ("leftover.png", None), ("upright.png", None), ("bright01.png", None), ("pair01.png", None)])
def test_camera_side(name, expected):
    assert camera_side(name) == expected


def _touch(folder, *names):
    folder.mkdir(exist_ok=True)
    for n in names:
        (folder / n).write_bytes(b"x")


def test_a_mixed_folder_pairs_by_key_in_sorted_order(tmp_path):
    _touch(tmp_path, "right02.jpg", "left10.jpg", "left02.jpg", "right10.jpg", "left01.jpg", "right01.jpg",
           "README.md", "overview.png")
    lefts, rights, others = split_mixed_folder(tmp_path)
    assert [p.name for p in lefts] == ["left01.jpg", "left02.jpg", "left10.jpg"]
    assert [p.name for p in rights] == ["right01.jpg", "right02.jpg", "right10.jpg"]
    assert others == ["README.md", "overview.png (its name says no camera)"]
    pairs, ignored = pair_images(tmp_path, tmp_path)
    assert [(a.name, b.name) for a, b in pairs] == [("left01.jpg", "right01.jpg"), ("left02.jpg", "right02.jpg"),
                                                    ("left10.jpg", "right10.jpg")]
    assert ignored == [f"{tmp_path}: README.md", f"{tmp_path}: overview.png (its name says no camera)"]


def test_a_folder_naming_one_camera_only_is_not_mixed(tmp_path):
    _touch(tmp_path, "left01.jpg", "left02.jpg", "img03.jpg")
    assert split_mixed_folder(tmp_path) is None
    with pytest.raises(RoboCalError, match="same folder, and no image name says its camera"):
        pair_images(tmp_path, tmp_path)


def test_an_image_without_its_partner_is_named(tmp_path):
    _touch(tmp_path, "left01.jpg", "right01.jpg", "left02.jpg", "right03.jpg")
    with pytest.raises(RoboCalError, match=r"2 left and 2 right images; left02.jpg, right03.jpg have no partner"):
        split_mixed_folder(tmp_path)


def test_two_images_of_one_camera_and_pair_are_refused(tmp_path):
    _touch(tmp_path, "left01.jpg", "left_01.png", "right01.jpg")
    with pytest.raises(RoboCalError, match="two left images of the same pair: left01.jpg and left_01.png"):
        split_mixed_folder(tmp_path)
