"""The image files a user gives for stereo pairs: a folder, a glob pattern or a list of files
per camera, listed by sorted name (`list_images`) and paired left with right by that order
(`pair_images`); the same folder for both cameras is one folder of both cameras' images told
apart by name (core.stereo.image_pairs)."""
from __future__ import annotations

import glob
from pathlib import Path
from typing import Sequence

from core.errors import RoboCalError
from core.images import IMAGE_SUFFIXES
from core.stereo.image_pairs import split_mixed_folder


def list_images(source: str | Path | Sequence[str | Path]) -> tuple[list[Path], list[str]]:
    """Image files of a folder, a glob pattern or a list of files, sorted by name.

    Returns (images, ignored) where `ignored` names files skipped for their type.
    """
    if isinstance(source, (str, Path)):
        sources = [source]
    else:
        sources = list(source)
    files: list[Path] = []
    ignored: list[str] = []
    for src in sources:
        p = Path(src)
        if p.is_dir():
            for child in sorted(p.iterdir()):
                if child.name.startswith(".") or not child.is_file():
                    continue
                if child.suffix.lower() in IMAGE_SUFFIXES:
                    files.append(child)
                else:
                    ignored.append(child.name)
        elif p.is_file():
            files.append(p)
        elif any(ch in str(src) for ch in "*?["):
            matches = sorted(Path(m) for m in glob.glob(str(src)))
            if not matches:
                raise RoboCalError("no file matches this pattern", source=src,
                                   hint="Check the folder and the pattern.")
            for m in matches:
                if not m.is_file():
                    continue
                if m.suffix.lower() in IMAGE_SUFFIXES:
                    files.append(m)
                else:
                    ignored.append(m.name)
        else:
            raise RoboCalError("no such folder or file", source=src, hint="Check the path.")
    files = sorted(dict.fromkeys(files), key=lambda f: (f.name, str(f)))
    return files, ignored


def pair_images(left: str | Path | Sequence, right: str | Path | Sequence
                ) -> tuple[list[tuple[Path, Path]], list[str]]:
    """Pair left and right images by sorted file name. Raises RoboCalError for unequal counts.
    The same folder for both cameras is one folder of both cameras' images told apart by name
    (leftNN / rightNN, core.stereo.image_pairs)."""
    if isinstance(left, (str, Path)) and isinstance(right, (str, Path)) and Path(left).is_dir() \
            and Path(right).is_dir() and Path(left).resolve() == Path(right).resolve():
        mixed = split_mixed_folder(left)
        if mixed is None:
            raise RoboCalError("the left and right images are the same folder, and no image name says its "
                               "camera", source=left,
                               hint="Name the images leftNN and rightNN, or give each camera's own folder.")
        lefts, rights, others = mixed
        return list(zip(lefts, rights)), [f"{left}: {n}" for n in others]
    lefts, ignored_l = list_images(left)
    rights, ignored_r = list_images(right)
    shown_l = _shown_source(left)
    shown_r = _shown_source(right)
    if not lefts or not rights:
        empty = shown_l if not lefts else shown_r
        raise RoboCalError("no image files found", source=empty,
                           hint=f"Give a folder with images ({', '.join(IMAGE_SUFFIXES[:5])}, ...).")
    if len(lefts) != len(rights):
        n = min(len(lefts), len(rights))
        extra = (lefts if len(lefts) > n else rights)[n:]
        names = ", ".join(f.name for f in extra[:5]) + (", ..." if len(extra) > 5 else "")
        raise RoboCalError(
            f"{len(lefts)} left images ({shown_l}) but {len(rights)} right images ({shown_r}); "
            f"pairs are matched by sorted file name, so {names} would have no partner",
            hint="Give both cameras' images of the same pairs, or remove the unmatched ones.")
    ignored = [f"{shown_l}: {n}" for n in ignored_l] + [f"{shown_r}: {n}" for n in ignored_r]
    return list(zip(lefts, rights)), ignored


def _shown_source(src) -> str:
    if isinstance(src, (str, Path)):
        return str(src)
    src = list(src)
    return str(Path(src[0]).parent) if src else "(none)"
