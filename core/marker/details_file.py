"""marker_details.json: what the report draws of the marker's last located live pair and last
verification, written by the Marker page (app/jobs/marker.py), read by the report
(core/report/marker.py). Image positions in px, lengths and errors in mm.

    details = MarkerDetails(marker="marker.npz", live=record, verification=numbers)
    details.write(project.folder / DETAILS_FILE, also={crop_path: png_bytes})
    details = MarkerDetails.read(path)       # RoboCalError naming the file and the field

The file (format DETAILS_FORMAT):
    {"format", "marker": marker file name,
     "live": {"pair", "error_mm", "point_mm", "sigma_mm", "disparity_px",
              "images": {"left"|"right": {"file" (a PNG crop, LIVE_IMAGES), "origin": [x0, y0] image px of
                         the crop's top-left pixel, "scale": crop px per image px, "image_size": [w, h],
                         "found", "reason",
                         "sift": {"mode", "matches", "agreeing", "agreeing_points", "other_points",
                                  "outline" (4x2), "reference", "roi" [x0, y0, x1, y1]},
                         "canny": {"ok", "roi", "edge_points" (on the four sides), "fitted" (polyline),
                                   "corners", "reference", "sigma_px"}}},   all points in image px
              "ssd": {"window" [h, w] px, "disparities" px, "criteria" (grey level² per pixel),
                      "searched" (pre-warped curve or null), "minimum" [d, C], "second" [d, C] or null,
                      "disparity" px, "reliability"},
              "sweep": {"sizes" px, "minima", "disparities" px, "reliabilities", "located" px}},
     "verification": {"poses", "located", "stereo", "depth_mm", "errors_mm", "sigmas_mm" (per pose,
                      null when not located), "median_error_mm", "rms_error_mm"}}
"""
from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

from core.errors import RoboCalError
from core.files import atomic_write_many, read_json, strict_json
from core.locks import output_locks

DETAILS_FILE = "marker_details.json"
DETAILS_FORMAT = "robocal.marker_details/1"
LIVE_IMAGES = {"left": "marker_live_left.png", "right": "marker_live_right.png"}
REWRITE = "Locate a live pair and run a verification on the Marker page to write it again."
LIVE_FIELDS = ("images",)                                       # what the report's live figures need
VERIFICATION_FIELDS = ("poses", "depth_mm", "errors_mm", "sigmas_mm")   # ... and its precision figure
PER_POSE = ("depth_mm", "errors_mm", "sigmas_mm")


@dataclass
class MarkerDetails:
    """The report's record of one trained marker (`marker`: its file name): the last located
    live pair (`live`, None when none was located) and the last verification's per-pose
    numbers (`verification`, None when none ran); both as in the file (see the module)."""
    marker: str
    live: dict | None = None
    verification: dict | None = None

    def to_dict(self) -> dict:
        data: dict = {"format": DETAILS_FORMAT, "marker": self.marker}
        if self.live is not None:
            data["live"] = self.live
        if self.verification is not None:
            data["verification"] = self.verification
        return data

    @classmethod
    def from_dict(cls, data, source: str | Path = DETAILS_FILE) -> "MarkerDetails":
        """The record in `data` (read from `source`), checked: RoboCalError naming the field."""
        if not isinstance(data, dict):
            raise RoboCalError(f"expected a JSON object, found {type(data).__name__}", source=source, hint=REWRITE)
        if data.get("format") != DETAILS_FORMAT:
            raise RoboCalError(f"format {data.get('format')!r}, expected {DETAILS_FORMAT!r}", source=source,
                               field="format", hint=REWRITE)
        marker = data.get("marker")
        if not isinstance(marker, str) or not marker:
            raise RoboCalError(f"expected the marker's file name, found {marker!r}", source=source, field="marker",
                               hint=REWRITE)
        live = _part(data, "live", LIVE_FIELDS, source)
        verification = _part(data, "verification", VERIFICATION_FIELDS, source)
        if verification is not None:
            for name in PER_POSE:
                values = verification[name]
                if not isinstance(values, list) or len(values) != verification["poses"]:
                    raise RoboCalError(f"expected one value per pose ({verification['poses']}), found {values!r:.60}",
                                       source=source, field=f"verification.{name}", hint=REWRITE)
        return cls(marker=marker, live=live, verification=verification)

    @classmethod
    def read(cls, path: str | Path) -> "MarkerDetails":
        return cls.from_dict(read_json(path), source=path)

    def text(self) -> str:
        """The file's text (compact JSON: the point lists are long)."""
        return json.dumps(strict_json(self.to_dict()), separators=(",", ":"), ensure_ascii=False) + "\n"

    def write(self, path: str | Path, also: dict[Path, bytes] | None = None) -> Path:
        """Write the file and the files in `also` (the live pair's crops) in one atomic write,
        holding their output locks."""
        files: dict = {**(also or {}), Path(path): self.text()}
        with output_locks(files):
            atomic_write_many(files)
        return Path(path)


def _part(data: dict, name: str, needed: tuple[str, ...], source) -> dict | None:
    """data[name] (None when absent), a dict holding the fields `needed`."""
    part = data.get(name)
    if part is None:
        return None
    if not isinstance(part, dict):
        raise RoboCalError(f"expected an object, found {type(part).__name__}", source=source, field=name,
                           hint=REWRITE)
    for key in needed:
        if key not in part:
            raise RoboCalError("missing", source=source, field=f"{name}.{key}", hint=REWRITE)
    if name == "verification" and (isinstance(part["poses"], bool) or not isinstance(part["poses"], int)
                                   or part["poses"] < 0):
        raise RoboCalError(f"expected a number of poses, found {part['poses']!r}", source=source,
                           field="verification.poses", hint=REWRITE)
    return part
