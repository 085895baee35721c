"""Generate the default end-effector marker: resources/markers/default.png and default.json.

Deterministic (no randomness beyond a fixed seed, OpenCV drawing only): running it again
gives byte-identical files.   python resources/markers/make_default_marker.py

The marker is an 800x800 px image of a 64 x 64 mm plate (12.5 px/mm): a white border around
a black outer square of 40 mm (pixels 150..649 in x and y, so its corners lie at 149.5 and
649.5 in the pixel-centre convention) whose inside holds an asymmetric pattern of white and
black shapes (no rotational or mirror symmetry) that gives SIFT plenty of texture, while a
solid black band of 4.8 mm keeps the outer square's edges clean for the Canny reference point.
The reference point is the centre of the outer square (399.5, 399.5).
"""
from __future__ import annotations

import json
from pathlib import Path

import cv2
import numpy as np

SIZE = 800            # png side, px
OUTER_LO, OUTER_HI = 150, 650   # outer black square occupies pixels [150, 650)
OUTER_MM = 40.0       # side of the outer black square, mm
BAND = 60             # solid black band inside the outer square, px
SHIFT = 4             # sub-pixel bits for OpenCV drawing
WHITE, BLACK = 255, 0


def _pts(points) -> np.ndarray:
    return np.round(np.asarray(points, dtype=float) * (1 << SHIFT)).astype(np.int32)


def _poly(img, points, colour):
    cv2.fillPoly(img, [_pts(points)], colour, cv2.LINE_AA, SHIFT)


def _circle(img, centre, radius, colour):
    c = _pts(centre)
    cv2.circle(img, (int(c[0]), int(c[1])), int(round(radius * (1 << SHIFT))), colour, -1, cv2.LINE_AA, SHIFT)


def _ellipse(img, centre, axes, angle, colour):
    c = _pts(centre)
    a = _pts(axes)
    cv2.ellipse(img, (int(c[0]), int(c[1])), (int(a[0]), int(a[1])), angle, 0, 360, colour, -1, cv2.LINE_AA, SHIFT)


def make_image() -> np.ndarray:
    img = np.full((SIZE, SIZE), WHITE, np.uint8)
    img[OUTER_LO:OUTER_HI, OUTER_LO:OUTER_HI] = BLACK
    lo, hi = OUTER_LO + BAND, OUTER_HI - BAND          # free inner area [210, 590)

    # A large white right triangle in the upper left (the "heavy" corner that breaks symmetry).
    _poly(img, [(lo, lo), (lo + 190, lo), (lo, lo + 150)], WHITE)
    # Black notch inside the triangle.
    _poly(img, [(lo + 22, lo + 22), (lo + 80, lo + 22), (lo + 22, lo + 64)], BLACK)

    # A white disc in the lower right with an off-centre black dot and a small white dot in it.
    _circle(img, (hi - 88, hi - 92), 70, WHITE)
    _circle(img, (hi - 70, hi - 118), 27, BLACK)
    _circle(img, (hi - 64, hi - 124), 8, WHITE)

    # A white horizontal bar at the bottom left with three black squares of different sizes.
    _poly(img, [(lo + 4, hi - 70), (lo + 196, hi - 70), (lo + 196, hi - 10), (lo + 4, hi - 10)], WHITE)
    for x, s in ((lo + 18, 30), (lo + 70, 22), (lo + 130, 40)):
        y = hi - 40 - s / 2
        _poly(img, [(x, y), (x + s, y), (x + s, y + s), (x, y + s)], BLACK)

    # A white chevron (arrow) pointing to the upper right.
    cx, cy = lo + 270, lo + 85
    _poly(img, [(cx - 40, cy + 55), (cx + 45, cy - 30), (cx + 45, cy + 20), (cx + 25, cy + 20),
                (cx + 25, cy + 5), (cx - 25, cy + 70)], WHITE)

    # A tilted white ellipse in the centre-left, with a black slot.
    _ellipse(img, (lo + 95, lo + 235), (62, 30), -28, WHITE)
    _ellipse(img, (lo + 105, lo + 230), (26, 9), -28, BLACK)

    # A white plus sign at the upper right.
    px, py = hi - 55, lo + 175
    _poly(img, [(px - 12, py - 42), (px + 12, py - 42), (px + 12, py - 12), (px + 42, py - 12),
                (px + 42, py + 12), (px + 12, py + 12), (px + 12, py + 42), (px - 12, py + 42),
                (px - 12, py + 12), (px - 42, py + 12), (px - 42, py - 12), (px - 12, py - 12)], WHITE)

    # A white quadrilateral (kite) left of the chevron.
    _poly(img, [(lo + 150, lo + 128), (lo + 205, lo + 100), (lo + 192, lo + 182), (lo + 138, lo + 170)], WHITE)

    # Small scattered white dots and squares (fixed seed) for fine texture, away from the shapes.
    rng = np.random.default_rng(20240601)
    placed = 0
    while placed < 14:
        x, y = rng.uniform(lo + 12, hi - 12, 2)
        r = rng.uniform(5, 11)
        patch = img[int(y - r - 6):int(y + r + 7), int(x - r - 6):int(x + r + 7)]
        if patch.size == 0 or patch.max() > 0:
            continue          # only on solid black, so the shapes above stay intact
        if placed % 2:
            _circle(img, (x, y), r, WHITE)
        else:
            _poly(img, [(x - r, y - r), (x + r, y - r * 0.6), (x + r * 0.7, y + r), (x - r * 0.8, y + r * 0.8)], WHITE)
        placed += 1

    # The solid band must stay black so the outer square's edges are clean.
    img[OUTER_LO:OUTER_LO + BAND, OUTER_LO:OUTER_HI] = BLACK
    img[OUTER_HI - BAND:OUTER_HI, OUTER_LO:OUTER_HI] = BLACK
    img[OUTER_LO:OUTER_HI, OUTER_LO:OUTER_LO + BAND] = BLACK
    img[OUTER_LO:OUTER_HI, OUTER_HI - BAND:OUTER_HI] = BLACK
    return img


def make_description() -> dict:
    px_per_mm = (OUTER_HI - OUTER_LO) / OUTER_MM
    a, b = OUTER_LO - 0.5, OUTER_HI - 0.5
    centre = (SIZE - 1) / 2.0
    return {
        "format": "robocal.marker/1",
        "name": "RoboCal default marker",
        "image": "default.png",
        "image_width": SIZE,
        "image_height": SIZE,
        "pixel_convention": "(0, 0) is the centre of the top-left pixel",
        "outer_size": OUTER_MM,
        "plate_size": [SIZE / px_per_mm, SIZE / px_per_mm],
        "outer_corners_px": [[a, a], [b, a], [b, b], [a, b]],
        "reference": "outer_square_centre",
        "reference_px": [centre, centre],
    }


def main(folder: Path | None = None) -> None:
    folder = Path(folder or Path(__file__).resolve().parent)
    ok, png = cv2.imencode(".png", make_image())
    assert ok
    (folder / "default.png").write_bytes(png.tobytes())
    (folder / "default.json").write_text(json.dumps(make_description(), indent=2) + "\n", encoding="utf-8")


if __name__ == "__main__":
    main()
