"""What every stereo importer shares: its result, and reading plain YAML/JSON numbers with
messages that name the file and the field."""
from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from core.errors import RoboCalError
from core.stereo.file import StereoFile

OPENCV_STYLE_HINT = ("RoboCal reads OpenCV files with K1, D1, K2, D2, R, T (or stereo_calib's M1, M2), and "
                     "Kalibr or OpenVINS camchains with cam0 and cam1 (see docs/file-formats.md).")
MAX_BYTES = 16 * 1024 * 1024     # a stereo calibration file is a few kB; MATLAB's with its points < 16 MB


@dataclass
class ImportedStereo:
    """A stereo calibration read from any supported file, with where it came from."""

    file: StereoFile
    kind: str                                  # the format, in words ("OpenCV FileStorage", "Kalibr camchain", …)
    sources: list[Path]
    notes: list[str] = field(default_factory=list)   # what was computed or assumed


def check_file(path: Path, *, text: bool = True) -> Path:
    """An existing, readable, not too large file (a text file unless `text` is False)."""
    if not path.exists():
        raise RoboCalError("file not found", source=path, hint="Check the path of the stereo calibration.")
    if not path.is_file():
        raise RoboCalError("not a file", source=path, hint="Give the stereo calibration file.")
    try:
        size = path.stat().st_size
        with path.open("rb") as handle:
            head = handle.read(64)
    except OSError as exc:
        raise RoboCalError(f"cannot read the file ({exc.strerror})", source=path) from exc
    if size > MAX_BYTES:
        raise RoboCalError(f"too large for a stereo calibration ({size / 1e6:.0f} MB)", source=path,
                           hint="Give the calibration file itself.")
    if text and b"\x00" in head:
        raise RoboCalError("not a text file", source=path, hint="Give a stereo calibration in YAML, XML or JSON.")
    return path


def load_yaml(path: Path):
    """A plain YAML document (pyyaml's safe loader), or a RoboCalError naming the file."""
    import yaml

    opencv_style = False
    try:
        text = path.read_text(encoding="utf-8-sig")
        opencv_style = text.startswith("%YAML:")
        if opencv_style:                       # OpenCV's header (Kalibr and OpenVINS files have it): not YAML 1.1's
            text = "#" + text
        return yaml.safe_load(text)
    except (yaml.YAMLError, UnicodeDecodeError, RecursionError) as exc:
        where = getattr(exc, "problem_mark", None)
        line = f" (line {where.line + 1})" if where is not None else ""
        if opencv_style:
            raise RoboCalError(f"an OpenCV-style YAML file (%YAML:1.0) of a layout RoboCal does not read{line}",
                               source=path, hint=OPENCV_STYLE_HINT) from None
        raise RoboCalError(f"not a readable YAML file{line}", source=path,
                           hint="Check the file; it must be plain YAML.") from None


def load_json(path: Path):
    try:
        return json.loads(path.read_text(encoding="utf-8"))
    except (json.JSONDecodeError, UnicodeDecodeError, RecursionError) as exc:
        raise RoboCalError(f"not valid JSON ({exc.__class__.__name__})", source=path,
                           hint="Export the file again.") from None


def entry(data, key: str, source, where: str = ""):
    """data[key], or a RoboCalError saying it is missing."""
    if not isinstance(data, dict) or key not in data:
        raise RoboCalError("missing", source=source, field=where + key,
                           hint="See docs/file-formats.md for the fields this format needs.")
    return data[key]


def numbers(value, shape: tuple[int, ...] | None, source, field_name: str) -> np.ndarray:
    """A finite float array of `shape` (None: any 1-D length) from nested lists of numbers."""
    def plain(v):
        if isinstance(v, bool) or isinstance(v, str) or v is None or isinstance(v, dict):
            raise TypeError
        return v

    try:
        flat = np.asarray(_walk(value, plain), dtype=float)
    except (TypeError, ValueError, OverflowError, RecursionError):
        raise RoboCalError("expected numbers" + (f" ({'x'.join(map(str, shape))})" if shape else ""),
                           source=source, field=field_name) from None
    if shape is None:
        flat = flat.ravel()
    elif flat.size != int(np.prod(shape)):
        raise RoboCalError(f"expected {'x'.join(map(str, shape))} numbers, got {flat.size}", source=source,
                           field=field_name)
    else:
        flat = flat.reshape(shape)
    if not np.all(np.isfinite(flat)):
        raise RoboCalError("contains values that are not finite numbers", source=source, field=field_name)
    return flat


def _walk(value, plain):
    if isinstance(value, (list, tuple)):
        return [_walk(v, plain) for v in value]
    return plain(value)


def whole(value, source, field_name: str, low: int = 1, high: int = 100_000) -> int:
    """A whole number within [low, high]."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise RoboCalError(f"expected a whole number, got {value!r:.40}", source=source, field=field_name)
    if not low <= value <= high:                       # also NaN (compares false) and huge integers
        raise RoboCalError(f"expected a whole number {low} … {high}, got {value!r:.40}", source=source,
                           field=field_name)
    if int(value) != value:
        raise RoboCalError(f"expected a whole number, got {value!r}", source=source, field=field_name)
    return int(value)
