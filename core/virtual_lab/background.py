"""The virtual lab's room: a cluttered wall behind the robot and the table it stands on.

Both are textured planes in the world (left camera) frame, so the left and right images see
them with the right parallax. Textures are procedural and seeded: a smooth lighting field,
grey rectangles (posters, boxes, shelves), circles, lines (cables), text-like blobs and a
fine paper-like grain on the wall; soft wood-like streaks on the table.

A room is never changed once made (its textures are read-only): labs of the same seed and rig
share one (`seeded_room`), a copy of a lab keeps its room, and the room as each camera of a rig
sees it is drawn once (`Room.canvases`).
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import cv2
import numpy as np

from core import transforms as tf
from core.stereo.rig import StereoRig
from core.virtual_lab.renderer import ImageComposer, camera_key, sampled_rays
from core.virtual_lab.rig import right_from_left

_LETTERS = "ABCDEFGHKLMNPRSTUVWXYZ0123456789-/#"


@dataclass
class TexturedPlane:
    texture: np.ndarray            # uint8 (h, w)
    px_per_mm: float
    world_from_plane: np.ndarray   # 4x4; plane (X, Y) mm -> texture px = px_per_mm · (X, Y)
    rect: tuple[float, float, float, float] | None = None   # drawn region in plane mm, None = all


class _RigKey:
    """A rig as a cache key: equal when its cameras and pose are equal; `rig` is the rig itself."""

    __slots__ = ("rig", "_key")

    def __init__(self, rig: StereoRig):
        self.rig = rig
        self._key = (camera_key(rig.left), camera_key(rig.right), rig.R.tobytes(), rig.T.tobytes())

    def __hash__(self) -> int:
        return hash(self._key)

    def __eq__(self, other) -> bool:
        return isinstance(other, _RigKey) and self._key == other._key


@dataclass(eq=False)
class Room:
    """The wall and the table; equal only to itself (a cache key), and shared by a lab's copies."""

    wall: TexturedPlane
    table: TexturedPlane | None

    def __deepcopy__(self, memo) -> "Room":
        return self

    def draw(self, composer: ImageComposer) -> None:
        composer.draw_wall(self.wall.texture, self.wall.world_from_plane, self.wall.px_per_mm)
        if self.table is not None:
            composer.draw_plane(self.table.texture, self.table.world_from_plane, self.table.px_per_mm,
                                self.table.rect)

    def canvases(self, rig: StereoRig) -> tuple[np.ndarray, np.ndarray]:
        """The room as the left and right cameras of `rig` see it (float32 canvases, read-only)."""
        return _room_canvases(self, _RigKey(rig))


@lru_cache(maxsize=8)
def _room_canvases(room: Room, rig: _RigKey) -> tuple[np.ndarray, np.ndarray]:
    left = ImageComposer(rig.rig.left, None)
    right = ImageComposer(rig.rig.right, right_from_left(rig.rig))
    for composer in (left, right):
        room.draw(composer)
        composer.canvas.setflags(write=False)
    return left.canvas, right.canvas


def _smooth_field(rng: np.random.Generator, shape, cells: int, lo: float, hi: float) -> np.ndarray:
    small = rng.uniform(lo, hi, (cells, max(2, int(cells * shape[1] / shape[0])))).astype(np.float32)
    return cv2.resize(small, (shape[1], shape[0]), interpolation=cv2.INTER_CUBIC)


def make_wall_texture(rng: np.random.Generator, width: int, height: int, px_per_mm: float) -> np.ndarray:
    """A cluttered wall, uint8 (height, width)."""
    img = np.clip(np.rint(_smooth_field(rng, (height, width), 4, 95.0, 165.0)), 0, 255).astype(np.uint8)
    s = px_per_mm
    shift = 3
    one = 1 << shift

    def P(x, y):
        return (int(round(x * one)), int(round(y * one)))

    # Rectangles: posters, boxes, shelves; some with an inner panel or a frame only.
    for _ in range(int(rng.integers(50, 70))):
        w, h = rng.uniform(40, 450, 2) * s
        x, y = rng.uniform(-0.05, 1.0) * width, rng.uniform(-0.05, 1.0) * height
        grey = int(rng.uniform(25, 235))
        if rng.random() < 0.75:
            cv2.rectangle(img, P(x, y), P(x + w, y + h), grey, -1, cv2.LINE_AA, shift)
            if rng.random() < 0.4:
                m = rng.uniform(0.1, 0.3)
                cv2.rectangle(img, P(x + m * w, y + m * h), P(x + (1 - m) * w, y + (1 - m) * h),
                              int(rng.uniform(25, 235)), -1, cv2.LINE_AA, shift)
        else:
            cv2.rectangle(img, P(x, y), P(x + w, y + h), grey, max(1, int(rng.uniform(4, 20) * s)), cv2.LINE_AA, shift)
    # Shelves: long thin boards with a few boxes standing on them.
    for _ in range(int(rng.integers(2, 4))):
        y = rng.uniform(0.1, 0.9) * height
        x = rng.uniform(-0.1, 0.6) * width
        L = rng.uniform(500, 1400) * s
        cv2.rectangle(img, P(x, y), P(x + L, y + 18 * s), int(rng.uniform(40, 90)), -1, cv2.LINE_AA, shift)
        bx = x + rng.uniform(10, 80) * s
        while bx < x + L - 60 * s:
            bw, bh = rng.uniform(40, 160) * s, rng.uniform(60, 260) * s
            cv2.rectangle(img, P(bx, y - bh), P(bx + bw, y), int(rng.uniform(30, 230)), -1, cv2.LINE_AA, shift)
            bx += bw + rng.uniform(5, 120) * s
    # Circles (clocks, plates, stickers).
    for _ in range(int(rng.integers(15, 25))):
        c = P(rng.uniform(0, width), rng.uniform(0, height))
        r = int(rng.uniform(15, 150) * s * one)
        grey = int(rng.uniform(25, 235))
        thick = -1 if rng.random() < 0.6 else max(1, int(rng.uniform(3, 15) * s))
        cv2.circle(img, c, r, grey, thick, cv2.LINE_AA, shift)
    # Lines (cables, edges of furniture).
    for _ in range(int(rng.integers(20, 35))):
        x, y = rng.uniform(0, width), rng.uniform(0, height)
        length, ang = rng.uniform(80, 900) * s, rng.uniform(0, np.pi)
        a = P(x, y)
        b = P(x + length * np.cos(ang), y + length * np.sin(ang))
        cv2.line(img, a, b, int(rng.uniform(20, 220)), max(1, int(rng.uniform(2, 10) * s)), cv2.LINE_AA, shift)
    # Text-like blobs (labels, notices).
    for _ in range(int(rng.integers(25, 40))):
        n = int(rng.integers(3, 12))
        text = "".join(rng.choice(list(_LETTERS), n))
        scale = float(rng.uniform(0.5, 2.2)) * s
        org = (int(rng.uniform(0, width * 0.9)), int(rng.uniform(0.05, 1.0) * height))
        font = [cv2.FONT_HERSHEY_SIMPLEX, cv2.FONT_HERSHEY_DUPLEX, cv2.FONT_HERSHEY_COMPLEX][int(rng.integers(0, 3))]
        cv2.putText(img, text, org, font, scale, int(rng.uniform(10, 240)), max(1, int(round(2 * scale))),
                    cv2.LINE_AA)
    # Broad soft gradients (light patches and shadows).
    img = img.astype(np.float32) * _smooth_field(rng, (height, width), 3, 0.8, 1.15)
    grain = rng.standard_normal((height, width)).astype(np.float32) * 5.0
    img += cv2.GaussianBlur(grain, (0, 0), 0.8)
    img = cv2.GaussianBlur(img, (0, 0), 0.7)
    return np.clip(np.rint(img), 0, 255).astype(np.uint8)


def make_table_texture(rng: np.random.Generator, width: int, height: int) -> np.ndarray:
    """A smooth, light wood-like table top, uint8 (height, width): low-frequency only, since
    it is seen at grazing angles."""
    base = _smooth_field(rng, (height, width), 3, 150.0, 185.0)
    streaks = rng.standard_normal((max(2, height // 24), 1)).astype(np.float32)
    streaks = cv2.resize(streaks, (width, height), interpolation=cv2.INTER_CUBIC) * 3.5
    img = base + streaks
    img = cv2.GaussianBlur(img, (0, 0), 3.0)
    return np.clip(np.rint(img), 0, 255).astype(np.uint8)


def make_room(rng: np.random.Generator, rig: StereoRig, *, wall_depth: float = 2500.0,
              table_height: float | None = None, table_near: float = 250.0,
              px_per_mm: float = 0.8) -> Room:
    """A room for `rig`: a wall at `wall_depth` (mm, left camera z) covering both views, and
    a table top at y = `table_height` (mm, left camera y, i.e. below the optical axis) from
    depth `table_near` to the wall (None: no table)."""
    rays = np.concatenate([sampled_rays(rig.left, 97), sampled_rays(rig.right, 97)])
    lo, hi = rays.min(axis=0), rays.max(axis=0)
    c = rig.right_centre
    x0 = min(lo[0] * wall_depth, c[0] + lo[0] * wall_depth) - 0.15 * wall_depth
    x1 = max(hi[0] * wall_depth, c[0] + hi[0] * wall_depth) + 0.15 * wall_depth
    y0 = lo[1] * wall_depth - 0.15 * wall_depth
    y1 = hi[1] * wall_depth + 0.15 * wall_depth
    w = int(np.ceil((x1 - x0) * px_per_mm))
    h = int(np.ceil((y1 - y0) * px_per_mm))
    wall = TexturedPlane(make_wall_texture(rng, w, h, px_per_mm), px_per_mm,
                         tf.make_transform(None, [x0, y0, wall_depth]))
    table = None
    if table_height is not None:
        tpx = 0.5
        depth = wall_depth - table_near
        tw = int(np.ceil((x1 - x0) * tpx))
        th = int(np.ceil(depth * tpx))
        # Plane x = world x, plane y = world z (away from the cameras), normal up (−y).
        R = np.column_stack([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]])
        table = TexturedPlane(make_table_texture(rng, tw, th), tpx,
                              tf.make_transform(R, [x0, table_height, table_near]),
                              rect=(0.0, x1 - x0, 0.0, depth))
    for plane in (wall, table):
        if plane is not None:
            plane.texture.setflags(write=False)
    return Room(wall, table)


def seeded_room(seed: np.random.SeedSequence, rig: StereoRig, **options) -> Room:
    """make_room with a generator of `seed`, made once for each of the last 8 different inputs
    (a wall texture takes about 0.1 s)."""
    return _seeded_room(seed.entropy, tuple(seed.spawn_key), _RigKey(rig), tuple(sorted(options.items())))


@lru_cache(maxsize=8)
def _seeded_room(entropy, spawn_key: tuple, rig: _RigKey, options: tuple) -> Room:
    seed = np.random.SeedSequence(entropy, spawn_key=spawn_key)
    return make_room(np.random.default_rng(seed), rig.rig, **dict(options))
