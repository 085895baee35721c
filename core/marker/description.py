"""The end-effector marker description `markers/*.json` (format robocal.marker/1).

A marker is a flat plate carrying a black outer square with an asymmetric inner pattern,
described by an image (png) and a JSON file giving its physical size. See
docs/file-formats.md, section "Marker description (markers/*.json)".

Marker (plate) frame, mm: origin at the reference point (the centre of the outer square),
x along the image's rows to the right, y towards the top of the image, z out of the printed
face (towards a camera that sees it). On the robot the plate lies in the tool frame's x-y
plane with this frame equal to the tool frame moved to the marker target point.
Image pixels use the pixel-centre convention ((0, 0) = centre of the top-left pixel):
  png = reference_px + px_per_mm · (X, −Y).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import cv2
import numpy as np

from core.errors import RoboCalError
from core.files import read_json
from core.validate import check_format, number, require, text, vector

FORMAT_FAMILY = "robocal.marker"
FORMAT_MAJOR = 1
FORMAT = f"{FORMAT_FAMILY}/{FORMAT_MAJOR}"
REFERENCES = ("outer_square_centre",)


@dataclass(eq=False)
class MarkerDescription:
    name: str
    image: str                       # png file name, relative to the JSON file's folder
    image_width: int
    image_height: int
    outer_size: float                # side of the outer black square, mm
    plate_size: tuple[float, float]  # (width, height) of the plate, mm; centred on the png centre
    outer_corners_px: np.ndarray     # (4, 2): top-left, top-right, bottom-right, bottom-left (png)
    reference_px: np.ndarray         # (2,) reference point in the png
    reference: str = "outer_square_centre"
    folder: Path | None = None       # where the png is looked up
    _image: np.ndarray | None = field(default=None, repr=False, compare=False)

    # -- geometry -------------------------------------------------------------------------
    @property
    def px_per_mm(self) -> float:
        """Scale of the png: mean side of the outer square in px over its size in mm."""
        c = self.outer_corners_px
        sides = np.linalg.norm(np.roll(c, -1, axis=0) - c, axis=1)
        return float(sides.mean() / self.outer_size)

    def png_from_plate(self, xy: np.ndarray) -> np.ndarray:
        """Plate coordinates (..., 2) mm -> png pixels (..., 2)."""
        xy = np.asarray(xy, dtype=float)
        s = self.px_per_mm
        return np.stack([self.reference_px[0] + s * xy[..., 0], self.reference_px[1] - s * xy[..., 1]], -1)

    def plate_from_png(self, uv: np.ndarray) -> np.ndarray:
        """png pixels (..., 2) -> plate coordinates (..., 2) mm."""
        uv = np.asarray(uv, dtype=float)
        s = self.px_per_mm
        return np.stack([(uv[..., 0] - self.reference_px[0]) / s, -(uv[..., 1] - self.reference_px[1]) / s], -1)

    def outer_corners(self) -> np.ndarray:
        """(4, 3) outer-square corners in the plate frame, mm (order as outer_corners_px)."""
        xy = self.plate_from_png(self.outer_corners_px)
        return np.concatenate([xy, np.zeros((4, 1))], axis=1)

    def plate_centre(self) -> np.ndarray:
        """(2,) centre of the plate in the plate frame (the png centre), mm."""
        c = np.array([(self.image_width - 1) / 2.0, (self.image_height - 1) / 2.0])
        return self.plate_from_png(c)

    def plate_corners(self) -> np.ndarray:
        """(4, 3) plate corners in the plate frame, mm: top-left, top-right, bottom-right, bottom-left."""
        cx, cy = self.plate_centre()
        w, h = self.plate_size[0] / 2.0, self.plate_size[1] / 2.0
        return np.array([[cx - w, cy + h, 0], [cx + w, cy + h, 0], [cx + w, cy - h, 0], [cx - w, cy - h, 0]])


    # -- image ----------------------------------------------------------------------------
    @property
    def image_path(self) -> Path:
        return (self.folder or Path(".")) / self.image

    def load_image(self) -> np.ndarray:
        """The marker png as 8-bit grayscale (H, W), cached."""
        if self._image is None:
            path = self.image_path
            data = np.fromfile(str(path), dtype=np.uint8) if path.is_file() else None
            img = cv2.imdecode(data, cv2.IMREAD_GRAYSCALE) if data is not None and data.size else None
            if img is None:
                raise RoboCalError("cannot read the marker image", source=path,
                                   hint="Check that the png named in the marker description exists.")
            if img.shape != (self.image_height, self.image_width):
                raise RoboCalError(f"image is {img.shape[1]}x{img.shape[0]} px, the description says "
                                   f"{self.image_width}x{self.image_height}", source=path)
            self._image = img
        return self._image

    # -- file -----------------------------------------------------------------------------
    def to_dict(self) -> dict:
        return {
            "format": FORMAT,
            "name": self.name,
            "image": self.image,
            "image_width": int(self.image_width),
            "image_height": int(self.image_height),
            "pixel_convention": "(0, 0) is the centre of the top-left pixel",
            "outer_size": float(self.outer_size),
            "plate_size": [float(v) for v in self.plate_size],
            "outer_corners_px": [[float(v) for v in c] for c in self.outer_corners_px],
            "reference": self.reference,
            "reference_px": [float(v) for v in self.reference_px],
        }

    @classmethod
    def from_dict(cls, data: dict, source: str | Path = "<marker>", folder: Path | None = None) -> "MarkerDescription":
        check_format(data, FORMAT_FAMILY, FORMAT_MAJOR, source)
        name = text(data.get("name", "marker"), source, "name")
        image = text(require(data, "image", source), source, "image")
        w = number(require(data, "image_width", source), source, "image_width", "px")
        h = number(require(data, "image_height", source), source, "image_height", "px")
        if w < 1 or h < 1 or w != int(w) or h != int(h):
            raise RoboCalError("image size must be positive whole pixels", source=source, field="image_width")
        outer = number(require(data, "outer_size", source), source, "outer_size", "mm")
        if outer <= 0:
            raise RoboCalError(f"must be positive, got {outer}", source=source, field="outer_size")
        plate = vector(require(data, "plate_size", source), 2, source, "plate_size", "mm")
        if min(plate) < outer:
            raise RoboCalError("the plate must be at least as large as the outer square", source=source,
                               field="plate_size")
        corners_data = require(data, "outer_corners_px", source)
        if not isinstance(corners_data, list) or len(corners_data) != 4:
            raise RoboCalError("expected 4 corners [x, y] (top-left, top-right, bottom-right, bottom-left)",
                               source=source, field="outer_corners_px")
        corners = np.array([vector(c, 2, source, f"outer_corners_px[{i}]", "px") for i, c in enumerate(corners_data)])
        reference = text(data.get("reference", "outer_square_centre"), source, "reference")
        if reference not in REFERENCES:
            raise RoboCalError(f"unknown reference {reference!r}", source=source, field="reference",
                               hint="Use 'outer_square_centre'.")
        ref = data.get("reference_px")
        ref_px = (np.array(vector(ref, 2, source, "reference_px", "px")) if ref is not None
                  else corners.mean(axis=0))
        if folder is None and str(source) != "<marker>":
            folder = Path(source).parent
        return cls(name=name, image=image, image_width=int(w), image_height=int(h), outer_size=outer,
                   plate_size=(plate[0], plate[1]), outer_corners_px=corners, reference_px=ref_px,
                   reference=reference, folder=folder)

    @classmethod
    def load(cls, path: str | Path) -> "MarkerDescription":
        path = Path(path)
        return cls.from_dict(read_json(path), source=path, folder=path.parent)

    @classmethod
    def default(cls) -> "MarkerDescription":
        """The shipped marker, resources/markers/default.json."""
        from core.resources import resource_path
        return cls.load(resource_path("markers", "default.json"))
