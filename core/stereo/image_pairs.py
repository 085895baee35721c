"""One folder holding both cameras' images, told apart by name.

The layout of OpenCV's stereo samples and of most labs: `left01.jpg … left14.jpg` beside
`right01.jpg … right14.jpg` in one folder. A file belongs to a camera when its name (without
the suffix, any case) starts or ends with the word "left" or "right", optionally joined by
"_", "-" or "." to the rest (`left_03.png`, `pair03-right.png`; not `leftover.png` or
`upright.png`); the rest is the pair's key,
and the two images with the same key make a pair, in sorted key order.
"""
from __future__ import annotations

import os
import re
from pathlib import Path

from core.errors import RoboCalError
from core.images import IMAGE_SUFFIXES

_SIDE = re.compile(r"^(?:(?P<pre>left|right)(?![a-z])[_.-]?(?P<key1>.*)"
                   r"|(?P<key2>.*?)[_.-]?(?<![a-z])(?P<post>left|right))$", re.IGNORECASE)


def camera_side(name: str) -> tuple[str, str] | None:
    """("left" | "right", the pair's key) for an image file name, or None when the name names
    no camera."""
    m = _SIDE.match(Path(name).stem)
    if m is None:
        return None
    side = (m.group("pre") or m.group("post")).lower()
    key = m.group("key1") if m.group("pre") else m.group("key2")
    return side, key.lower()


def split_mixed_folder(folder: str | Path) -> tuple[list[Path], list[Path], list[str]] | None:
    """The (left, right) images of a folder that holds both cameras' images, paired by key in
    sorted order, and the names of the other files (not images, or naming no camera); None when
    the folder's image names do not name both cameras. Raises RoboCalError naming the images
    that have no partner."""
    folder = Path(folder)
    if not folder.is_dir():
        return None
    sides: dict[str, dict[str, Path]] = {"left": {}, "right": {}}
    others: list[str] = []
    for child in sorted(folder.iterdir()):
        if child.name.startswith(".") or not child.is_file():
            continue
        image = child.suffix.lower() in IMAGE_SUFFIXES
        named = camera_side(child.name) if image else None
        if named is None:
            others.append(f"{child.name} (its name says no camera)" if image else child.name)
            continue
        side, key = named
        if key in sides[side]:
            raise RoboCalError(f"two {side} images of the same pair: {sides[side][key].name} and {child.name}",
                               source=folder, hint="Keep one image per camera and pair in the folder.")
        sides[side][key] = child
    left, right = sides["left"], sides["right"]
    if not left or not right:
        return None
    alone = sorted(set(left) ^ set(right))
    if alone:
        names = [(left.get(k) or right[k]).name for k in alone]
        shown = ", ".join(names[:5]) + (", ..." if len(names) > 5 else "")
        raise RoboCalError(f"{len(left)} left and {len(right)} right images; {shown} "
                           f"{'has' if len(names) == 1 else 'have'} no partner of the other camera",
                           source=folder,
                           hint="Each leftNN image needs its rightNN partner: add it or remove the unmatched ones.")
    keys = sorted(left)
    return [left[k] for k in keys], [right[k] for k in keys], others


def swap_camera_folders(folder: str | Path) -> bool:
    """Exchange `folder`/left and `folder`/right (pairs saved for the wrong cameras), by three
    renames within the folder; False when the folder does not hold both. Raises RoboCalError
    when an interrupted swap left its temporary folder behind."""
    folder = Path(folder)
    left, right, aside = folder / "left", folder / "right", folder / ".left-being-swapped"
    if aside.exists():
        raise RoboCalError("an earlier swap of the cameras' folders was interrupted", source=aside,
                           hint="Look at left/, right/ and this folder, put the images back by hand, then remove it.")
    if not (left.is_dir() and right.is_dir()):
        return False
    os.rename(left, aside)
    os.rename(right, left)
    os.rename(aside, right)
    return True
