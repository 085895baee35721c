"""Renders realistic 8-bit grayscale camera images of planar objects, geometrically exact.

Geometry follows core/camera.py exactly: every pixel centre ((0, 0) = centre of the top-left
pixel) is turned into its undistorted viewing ray once per camera (`ray_map`, cached), and a
plane seen by the camera is evaluated where that ray meets it. So an object point lands
precisely where `CameraModel.project` puts it, distortion included.

- Checkerboards are evaluated analytically at the pixel centres with an exact box-filter
  coverage across each edge (signed distance to the nearest grid line, in pixels), which
  keeps every edge and corner where the model puts it with no sampling error.
- Textured plates (the marker) are supersampled (3x3 per pixel, sub-pixel rays interpolated
  from the ray map), sampled from a mip level of the texture with `cv2.remap`, and averaged.
  A plate with a `square` (the marker's outer square, whose edges give its reference point)
  has that square's outline drawn with the exact area coverage of each pixel instead: the
  texture inside and outside it are sampled as above, each without the outline, and mixed by
  the fraction of the pixel the square covers. Its optical blur is exact too (see `finish`).
- Background: a textured wall plane (parallax-correct in both cameras) and thick bars (robot links).
- `finish` adds optical blur (Gaussian), uneven lighting (vignetting and a smooth gradient),
  sensor noise (read noise plus shot noise) and quantises to uint8.

A lens blurs the scene before the pixels integrate it; blurring the rendered pixels instead
(a sampled Gaussian kernel on the pixel grid, as `finish` does) changes an edge's profile with
its position within the pixel when the blur is under about a pixel: a straight edge nearly
along a pixel axis, fitted by the marker's edge model, then moves by up to ±0.05 px as it
crosses a pixel. So the marker's outline is given the blur a lens gives it (the pixel
footprint convolved with the Gaussian, in closed form), as a correction added after `finish`'s
blur; whatever is drawn over it later hides the correction with it.

Everything here is plain numpy/OpenCV in float32 with cached per-camera maps; the outline's
coverage is computed in float64 with scipy's normal CDF.
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import cv2
import numpy as np
from scipy.special import ndtr

from core.stereo.board import Board
from core.camera import CameraModel

SUPERSAMPLE = 3
BLUR_SIGMA = 0.7          # px, optical blur (Gaussian sigma)
NEAR = 1.0                # mm, nearest depth drawn
_SQRT_2PI = float(np.sqrt(2.0 * np.pi))


# -- per-camera cached maps -------------------------------------------------------------------

def camera_key(camera: CameraModel) -> tuple:
    """The camera as a cache key: its intrinsics' and distortion's bytes and its image size."""
    return (camera.K.tobytes(), camera.dist.tobytes(), int(camera.width), int(camera.height))


def _rays(K: np.ndarray, dist: np.ndarray, xs: np.ndarray, ys: np.ndarray) -> np.ndarray:
    """(N, 2) float32 ideal normalised coordinates of the pixels (xs, ys) (float64): each pixel's
    ray is computed on its own, so a pixel has the same ray in any set of pixels."""
    pts = np.stack([xs.ravel(), ys.ravel()], axis=1).reshape(-1, 1, 2)
    criteria = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 50, 1e-12)
    xy = cv2.undistortPoints(pts, K, dist, R=np.eye(3), P=np.eye(3), criteria=criteria)
    return xy.reshape(-1, 2).astype(np.float32)


@lru_cache(maxsize=16)        # 10.5 MB and about 0.3 s each at 1280 × 1024: the cameras of 8 rigs
def _ray_map_cached(key: tuple) -> np.ndarray:
    K = np.frombuffer(key[0]).reshape(3, 3)
    dist = np.frombuffer(key[1])
    width, height = key[2], key[3]
    ys, xs = np.mgrid[-1:height + 1, -1:width + 1].astype(np.float64)
    out = _rays(K, dist, xs, ys).reshape(height + 2, width + 2, 2)
    out.setflags(write=False)
    return out


def ray_map(camera: CameraModel, padded: bool = False) -> np.ndarray:
    """Ideal normalised image coordinates (x, y) of every pixel centre: (H, W, 2) float32.

    The viewing ray of pixel (u, v) is (x, y, 1) in the camera frame. With `padded`, the map
    has one extra pixel on every side ((H + 2, W + 2, 2), index [v + 1, u + 1])."""
    m = _ray_map_cached(camera_key(camera))
    return m if padded else m[1:-1, 1:-1]


def sampled_rays(camera: CameraModel, step: int) -> np.ndarray:
    """`ray_map(camera).reshape(-1, 2)[::step]`, every `step`-th pixel in row order, without
    computing the whole map (the same values)."""
    key = camera_key(camera)
    width, height = key[2], key[3]
    flat = np.arange(0, width * height, step)
    return _rays(np.frombuffer(key[0]).reshape(3, 3), np.frombuffer(key[1]), (flat % width).astype(np.float64),
                 (flat // width).astype(np.float64))


@lru_cache(maxsize=8)
def _vignetting_cached(key: tuple, strength: float) -> np.ndarray:
    K = np.frombuffer(key[0]).reshape(3, 3)
    width, height = key[2], key[3]
    x = (np.arange(width, dtype=np.float32) - K[0, 2]) / K[0, 0]
    y = (np.arange(height, dtype=np.float32) - K[1, 2]) / K[1, 1]
    r2 = y[:, None] ** 2 + x[None, :] ** 2
    v = (1.0 / (1.0 + r2)) ** 2                      # cos^4 law of a thin lens
    v = 1.0 - strength * (1.0 - v) / max(float(1.0 - v.min()), 1e-6)
    out = v.astype(np.float32)
    out.setflags(write=False)
    return out


def vignetting(camera: CameraModel, strength: float = 0.25) -> np.ndarray:
    """(H, W) float32 relative illumination: 1 at the principal point, 1 − strength at the
    farthest corner (cos⁴ fall-off)."""
    return _vignetting_cached(camera_key(camera), float(strength))


# -- textures -----------------------------------------------------------------------------

@dataclass
class PlateTexture:
    """A planar texture (e.g. the marker png) and its mip levels, in grey levels (float32).

    `px_per_mm` and `origin_px` map plate coordinates to level-0 texture pixels:
    tex = origin_px + px_per_mm · (X, sign_y · Y). `rect` is the plate outline in plate mm
    (xmin, xmax, ymin, ymax); outside the texture but inside the plate the value is `fill`.

    `square` (xmin, xmax, ymin, ymax, plate mm), if given, is a dark square on a bright plate
    whose outline is drawn exactly (see the module): `split_levels` hold two channels, the
    texture with everything outside the square made black, and with everything inside it
    white (`fill`); neither has the outline."""

    levels: list[np.ndarray]
    px_per_mm: float
    origin_px: tuple[float, float]
    rect: tuple[float, float, float, float]
    fill: float
    sign_y: float = -1.0
    square: tuple[float, float, float, float] | None = None
    split_levels: list[np.ndarray] | None = None

    @classmethod
    def from_image(cls, image: np.ndarray, px_per_mm: float, origin_px, rect, *, black: float = 25.0,
                   white: float = 215.0, sign_y: float = -1.0, max_levels: int = 6,
                   square=None) -> "PlateTexture":
        """An 8-bit image mapped linearly from 0..255 to black..white grey levels; `square`
        (plate mm) as in the class."""
        level = (black + (white - black) * (image.astype(np.float32) / 255.0)).astype(np.float32)
        origin = (float(origin_px[0]), float(origin_px[1]))
        split = None
        if square is not None:
            square = tuple(float(v) for v in square)
            ys, xs = np.mgrid[0:level.shape[0], 0:level.shape[1]].astype(np.float32)
            X = (xs - origin[0]) / px_per_mm
            Y = (ys - origin[1]) / (sign_y * px_per_mm)
            within = (X > square[0]) & (X < square[1]) & (Y > square[2]) & (Y < square[3])   # texel centres
            split = _mip_levels(np.dstack([np.where(within, level, np.float32(black)),
                                           np.where(within, np.float32(white), level)]), max_levels)
        return cls(_mip_levels(level, max_levels), float(px_per_mm), origin,
                   tuple(float(v) for v in rect), float(white), sign_y, square, split)


def _mip_levels(level0: np.ndarray, max_levels: int) -> list[np.ndarray]:
    levels = [level0.astype(np.float32)]
    while len(levels) < max_levels and min(levels[-1].shape[:2]) > 16:
        levels.append(cv2.pyrDown(levels[-1]))
    return levels


# -- composing one image ---------------------------------------------------------------------

class ImageComposer:
    """Builds one camera image in float32 grey levels, then `finish` makes the uint8 image.

    `cam_from_world` (4x4) takes world points (the virtual lab uses the left camera frame as
    the world) into this camera's frame."""

    def __init__(self, camera: CameraModel, cam_from_world: np.ndarray | None = None, fill: float = 128.0,
                 blur_sigma: float = BLUR_SIGMA):
        self.camera = camera
        self.cam_from_world = np.eye(4) if cam_from_world is None else np.asarray(cam_from_world, dtype=float)
        self.rays = ray_map(camera, padded=True)
        self.canvas = np.full((camera.height, camera.width), float(fill), np.float32)
        self.blur_sigma = float(blur_sigma)          # px, the optical blur `finish` gives
        self._after_blur: np.ndarray | None = None   # grey levels added after the blur (see the module)

    def _hide_after_blur(self, y0: int, y1: int, x0: int, x1: int, alpha) -> None:
        """Something drawn over the window with coverage `alpha` hides the corrections under it."""
        if self._after_blur is not None:
            self._after_blur[y0:y1, x0:x1] *= 1.0 - alpha

    # geometry helpers ---------------------------------------------------------------------
    def _cam_from(self, world_from_obj: np.ndarray) -> np.ndarray:
        return self.cam_from_world @ np.asarray(world_from_obj, dtype=float)

    @staticmethod
    def _plane_homography(cam_from_plane: np.ndarray) -> np.ndarray:
        """3x3 H with (X, Y, 1) ~ H · (x, y, 1): normalised image coords -> plane coords."""
        M = np.column_stack([cam_from_plane[:3, 0], cam_from_plane[:3, 1], cam_from_plane[:3, 3]])
        return np.linalg.inv(M)

    def _smallest_scale(self, cam_from_plane: np.ndarray) -> float:
        """Image px per plane mm at the plane's origin along its most compressed direction: the
        smaller singular value of d(pixel)/d(plane X, Y) of the pinhole (distortion left out)."""
        P = cam_from_plane[:3, 3]
        z = max(float(P[2]), NEAR)
        A = cam_from_plane[:3, :2]
        J = (A[:2] * z - np.outer(P[:2], A[2])) / z ** 2                  # d(x, y normalised)/d(X, Y)
        J = J * np.array([[self.camera.fx], [self.camera.fy]])
        return float(np.linalg.svd(J, compute_uv=False).min())

    def _window(self, cam_from_plane: np.ndarray, rect, pad: int = 3):
        """Pixel window (x0, y0, x1, y1) holding the plane rectangle, or None if not visible."""
        xmin, xmax, ymin, ymax = rect
        t = np.linspace(0.0, 1.0, 17)
        edges = np.concatenate([
            np.stack([xmin + (xmax - xmin) * t, np.full_like(t, ymin)], 1),
            np.stack([np.full_like(t, xmax), ymin + (ymax - ymin) * t], 1),
            np.stack([xmax - (xmax - xmin) * t, np.full_like(t, ymax)], 1),
            np.stack([np.full_like(t, xmin), ymax - (ymax - ymin) * t], 1)])
        P = edges @ cam_from_plane[:3, :2].T + cam_from_plane[:3, 3]
        W, H = self.camera.width, self.camera.height
        if np.all(P[:, 2] <= NEAR):
            return None
        if np.any(P[:, 2] <= NEAR):
            return (0, 0, W, H)
        xy = P[:, :2] / P[:, 2:3]
        # Outside the undistortion's valid range the polynomial is meaningless: use the full image.
        r_img = float(np.abs(self.rays).max()) * 1.5
        if np.any(np.abs(xy) > r_img):
            return (0, 0, W, H)
        uv = self.camera.normalized_to_pixels(xy)
        x0 = int(np.floor(uv[:, 0].min())) - pad
        x1 = int(np.ceil(uv[:, 0].max())) + pad + 1
        y0 = int(np.floor(uv[:, 1].min())) - pad
        y1 = int(np.ceil(uv[:, 1].max())) + pad + 1
        x0, y0, x1, y1 = max(x0, 0), max(y0, 0), min(x1, W), min(y1, H)
        if x0 >= x1 or y0 >= y1:
            return None
        return (x0, y0, x1, y1)

    # drawing -----------------------------------------------------------------------------
    def draw_wall(self, texture: np.ndarray, world_from_wall: np.ndarray, px_per_mm: float) -> None:
        """A textured plane covering the whole view (see `draw_plane`)."""
        self.draw_plane(texture, world_from_wall, px_per_mm)

    def draw_plane(self, texture: np.ndarray, world_from_plane: np.ndarray, px_per_mm: float,
                   rect=None) -> None:
        """A textured plane sampled once per pixel (for smooth, far background surfaces).

        Plane coordinates (X, Y) mm map to texture pixels px_per_mm · (X, Y); only the part
        inside `rect` (xmin, xmax, ymin, ymax in plane mm), if given, and in front of the
        camera is drawn."""
        H = self._plane_homography(self._cam_from(world_from_plane))
        rays = self.rays[1:-1, 1:-1]
        X, Y, ok = _apply_homography(rays, H)
        if rect is not None:
            xmin, xmax, ymin, ymax = rect
            ok &= (X >= xmin) & (X <= xmax) & (Y >= ymin) & (Y <= ymax)
        if not ok.any():
            return
        s = np.float32(px_per_mm)
        img = cv2.remap(texture, X * s, Y * s, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REFLECT_101)
        self.canvas[ok] = img[ok].astype(np.float32)
        self._hide_after_blur(0, self.camera.height, 0, self.camera.width, ok)

    def draw_checkerboard(self, board: Board, world_from_board: np.ndarray, *, white: float = 215.0,
                          black: float = 28.0, margin: float = 1.0) -> None:
        """A checkerboard (board frame of core/board.py) with a white margin of `margin`
        squares around the outer squares, composited with exact anti-aliasing."""
        sq = board.square
        cam_from_board = self._cam_from(world_from_board)
        lo = -(1.0 + margin) * sq
        rect = (lo, (board.cols + margin) * sq, lo, (board.rows + margin) * sq)
        win = self._window(cam_from_board, rect)
        if win is None:
            return
        x0, y0, x1, y1 = win
        # Evaluated in place on a few window-sized float64 buffers (the same operations in the
        # same order as the plain expressions in the comments, so the same values).
        x = self.rays[y0 + 1:y1 + 1, x0 + 1:x1 + 1, 0].astype(np.float64)
        y = self.rays[y0 + 1:y1 + 1, x0 + 1:x1 + 1, 1].astype(np.float64)
        Hm = self._plane_homography(cam_from_board)
        tmp = np.empty_like(x)
        den = _homography_row(Hm, 2, x, y, tmp)
        ok = den > 0
        all_ok = bool(ok.all())
        if not all_ok:
            den[~ok] = 1.0                          # np.where(ok, den, 1.0)
        u = _homography_row(Hm, 0, x, y, tmp)
        u /= den
        v = _homography_row(Hm, 1, x, y, tmp)
        v /= den
        # |grad u|, |grad v| in mm per pixel (pinhole part; distortion changes it by < 5 %):
        # hypot((Hm[r, 0] − P·Hm[2, 0]) / (den·fx), (Hm[r, 1] − P·Hm[2, 1]) / (den·fy)), P = u, v.
        den_x, den_y = den * self.camera.fx, np.multiply(den, self.camera.fy, out=den)
        del den
        gu = _gradient_norm(u, Hm, 0, den_x, den_y, out=x, scratch=tmp)
        gv = _gradient_norm(v, Hm, 1, den_x, den_y, out=y, scratch=tmp)
        del x, y, den_x, den_y, tmp
        eu, ou, au = _checker_axis(u, gu, sq, board.cols, margin)
        ev, ov, av = _checker_axis(v, gv, sq, board.rows, margin)
        alpha = np.multiply(au, av, out=au)         # np.where(ok, au·av, 0)
        blackness = np.multiply(eu, ev, out=eu)     # np.where(ok, eu·ev + ou·ov, 0)
        blackness += np.multiply(ou, ov, out=ov)
        if not all_ok:
            alpha[~ok] = 0.0
            blackness[~ok] = 0.0
        bg = self.canvas[y0:y1, x0:x1]
        out = np.multiply(alpha, white - bg, out=av)  # bg + alpha·(white − bg) − (white − black)·blackness
        out += bg
        blackness *= white - black
        out -= blackness
        self._hide_after_blur(y0, y1, x0, x1, alpha)
        self.canvas[y0:y1, x0:x1] = out

    def draw_plate(self, texture: PlateTexture, world_from_plate: np.ndarray,
                   supersample: int = SUPERSAMPLE) -> None:
        """A textured rectangular plate (e.g. the marker), supersampled `supersample`² per pixel."""
        cam_from_plate = self._cam_from(world_from_plate)
        win = self._window(cam_from_plate, texture.rect)
        if win is None:
            return
        x0, y0, x1, y1 = win
        s = int(supersample)
        h, w = y1 - y0, x1 - x0
        pad = self.rays[y0:y1 + 2, x0:x1 + 2]
        # Sub-pixel rays: hi-res pixel J <-> pixel (J - (s - 1) / 2) / s, as CameraModel.scaled.
        hi = cv2.resize(pad, ((w + 2) * s, (h + 2) * s), interpolation=cv2.INTER_LINEAR)
        hi = hi[s:s * (h + 1), s:s * (w + 1)]
        Hm = self._plane_homography(cam_from_plate)
        X, Y, ok = _apply_homography(hi, Hm)
        # Mip level: texels no smaller than the samples in any direction, so that bilinear
        # sampling turns every texture edge into a ramp at least one sample wide and the box
        # average then places it to a fraction of a sample. Finer texels quantise edges to 1/s px:
        # on a tilted plate the texture is compressed across the tilt, and an edge nearly
        # parallel to a pixel axis then moved in steps as the plate moved (its position swung by
        # ±0.02 px with a period of one pixel), so the level follows the most compressed direction.
        scale_img = s * self._smallest_scale(cam_from_plate)             # samples per mm
        level = 0
        while level + 1 < len(texture.levels) and texture.px_per_mm / 2 ** level > scale_img:
            level += 1
        f = 1.0 / 2 ** level
        mx = (texture.origin_px[0] + texture.px_per_mm * X) * f
        my = (texture.origin_px[1] + texture.sign_y * texture.px_per_mm * Y) * f
        xmin, xmax, ymin, ymax = texture.rect
        a = (ok & (X >= xmin) & (X <= xmax) & (Y >= ymin) & (Y <= ymax)).astype(np.float32)
        alpha = _pixel_means(a, w, h)

        def averaged(levels):
            tex = cv2.remap(levels[level], mx, my, cv2.INTER_LINEAR,
                            borderMode=cv2.BORDER_CONSTANT, borderValue=texture.fill)
            tex *= a[..., None] if tex.ndim == 3 else a           # a · tex, in place
            return _pixel_means(tex, w, h)

        self._hide_after_blur(y0, y1, x0, x1, alpha)
        if texture.square is None:
            colour = averaged(texture.levels)
        else:
            cover, blurred = self._square_coverage(Hm, texture.square, (x0, y0, x1, y1))
            split = averaged(texture.split_levels)
            inside, outside = split[..., 0], split[..., 1]
            colour = cover * inside + (1.0 - cover) * outside
            if self.blur_sigma > 0:
                pixel_blur = cv2.GaussianBlur(cover, (0, 0), self.blur_sigma, borderType=cv2.BORDER_REPLICATE)
                if self._after_blur is None:
                    self._after_blur = np.zeros_like(self.canvas)
                self._after_blur[y0:y1, x0:x1] += (blurred - pixel_blur) * (inside - outside)
        bg = self.canvas[y0:y1, x0:x1]
        self.canvas[y0:y1, x0:x1] = bg * (1.0 - alpha) + colour

    def _square_coverage(self, Hm: np.ndarray, square, win) -> tuple[np.ndarray, np.ndarray]:
        """Fraction of each pixel of the window (x0, y0, x1, y1) covered by the plate square
        (xmin, xmax, ymin, ymax, plate mm), sharp and as the lens blurs it (`blur_sigma`): for
        each side, the exact coverage of a unit pixel by a straight edge at the pixel centre's
        distance from it (first order, in px), with the edge's direction in the image; the four
        sides multiplied (exact away from the corners). `Hm`: normalised image coordinates ->
        plate mm (`_plane_homography`)."""
        x0, y0, x1, y1 = win
        pad = self.rays[y0:y1 + 2, x0:x1 + 2].astype(np.float64)
        rays = pad[1:-1, 1:-1]
        dxy_du = 0.5 * (pad[1:-1, 2:] - pad[1:-1, :-2])          # d(x, y normalised)/d(pixel u)
        dxy_dv = 0.5 * (pad[2:, 1:-1] - pad[:-2, 1:-1])
        x, y = rays[..., 0], rays[..., 1]
        den = Hm[2, 0] * x + Hm[2, 1] * y + Hm[2, 2]
        ok = den > 0
        den = np.where(ok, den, 1.0)
        cover = ok.astype(np.float64)
        blurred = cover.copy()
        reach = 1.0 + 6.0 * self.blur_sigma           # px: the pixel's half-diagonal and the blur's tail
        for row, bounds in ((0, square[0:2]), (1, square[2:4])):
            P = (Hm[row, 0] * x + Hm[row, 1] * y + Hm[row, 2]) / den          # X or Y, mm
            gx = (Hm[row, 0] - P * Hm[2, 0]) / den                             # dP/dx
            gy = (Hm[row, 1] - P * Hm[2, 1]) / den
            gu = gx * dxy_du[..., 0] + gy * dxy_du[..., 1]                     # dP/du, mm per px
            gv = gx * dxy_dv[..., 0] + gy * dxy_dv[..., 1]
            g = np.maximum(np.hypot(gu, gv), 1e-12)
            c, sn = np.abs(gu) / g, np.abs(gv) / g
            for d in ((P - bounds[0]) / g, (bounds[1] - P) / g):
                near = np.abs(d) < reach                       # elsewhere the pixel is in or out
                dn, cn, sn_n = d[near], c[near], sn[near]
                step = (d > 0).astype(np.float64)
                sharp, soft = step, step.copy()
                sharp[near] = _edge_coverage(dn, cn, sn_n)
                soft[near] = _blurred_edge_coverage(dn, cn, sn_n, self.blur_sigma)
                cover *= sharp
                blurred *= soft
        return cover.astype(np.float32), blurred.astype(np.float32)

    def draw_bars(self, starts: np.ndarray, ends: np.ndarray, radii, shades) -> None:
        """Thick bars (robot links) between world points, far ones first, anti-aliased,
        with a lighter stripe along each bar for a cylinder-like look."""
        starts = np.atleast_2d(np.asarray(starts, dtype=float))
        ends = np.atleast_2d(np.asarray(ends, dtype=float))
        radii = np.broadcast_to(np.asarray(radii, dtype=float), (len(starts),))
        shades = np.broadcast_to(np.asarray(shades, dtype=float), (len(starts),))
        Rc, tc = self.cam_from_world[:3, :3], self.cam_from_world[:3, 3]
        A = starts @ Rc.T + tc
        B = ends @ Rc.T + tc
        order = np.argsort(-(A[:, 2] + B[:, 2]))
        for i in order:
            self._bar(A[i], B[i], radii[i], shades[i])

    def _bar(self, A, B, radius, shade) -> None:
        near = 20.0
        if A[2] < near and B[2] < near:
            return
        if A[2] < near or B[2] < near:   # clip at the near plane
            t = (near - A[2]) / (B[2] - A[2])
            P = A + t * (B - A)
            A, B = (P, B) if A[2] < near else (A, P)
        cam = self.camera
        ends = cam.project(np.stack([A, B]))
        if not np.all(np.isfinite(ends)):
            return
        wa = radius * 0.5 * (cam.fx + cam.fy) / A[2]
        wb = radius * 0.5 * (cam.fx + cam.fy) / B[2]
        d = ends[1] - ends[0]
        L = np.hypot(*d)
        n = np.array([-d[1], d[0]]) / L if L > 1e-6 else np.array([0.0, 1.0])
        for width_frac, offset_frac, value in ((1.0, 0.0, shade), (0.35, -0.3, min(shade * 1.45 + 15, 235.0))):
            quad = np.array([ends[0] + n * wa * (offset_frac + width_frac), ends[1] + n * wb * (offset_frac + width_frac),
                             ends[1] + n * wb * (offset_frac - width_frac), ends[0] + n * wa * (offset_frac - width_frac)])
            if width_frac == 1.0:
                self._fill(quad, value, circles=((ends[0], wa), (ends[1], wb)))
            else:
                self._fill(quad, value)

    def _fill(self, polygon: np.ndarray, value: float, circles=()) -> None:
        """Anti-aliased fill of a convex polygon (plus discs) with a grey value."""
        pts = [polygon] + [np.array([c + r * np.array([np.cos(a), np.sin(a)]) for a in np.linspace(0, 2 * np.pi, 24)])
                           for c, r in circles]
        allp = np.concatenate(pts)
        H, W = self.canvas.shape
        x0 = max(int(np.floor(allp[:, 0].min())) - 2, 0)
        y0 = max(int(np.floor(allp[:, 1].min())) - 2, 0)
        x1 = min(int(np.ceil(allp[:, 0].max())) + 3, W)
        y1 = min(int(np.ceil(allp[:, 1].max())) + 3, H)
        if x0 >= x1 or y0 >= y1:
            return
        mask = np.zeros((y1 - y0, x1 - x0), np.uint8)
        shift = 4
        for p in pts:
            q = np.round((p - [x0, y0]) * (1 << shift)).astype(np.int32)
            cv2.fillConvexPoly(mask, q, 255, cv2.LINE_AA, shift)
        a = mask.astype(np.float32)
        a /= 255.0
        region = self.canvas[y0:y1, x0:x1]
        mixed = np.subtract(value, region)          # region + a·(value − region), in place
        mixed *= a
        region += mixed
        self._hide_after_blur(y0, y1, x0, x1, a)

    # finishing ---------------------------------------------------------------------------
    def finish(self, rng: np.random.Generator | None = None, noise: float = 0.5, *,
               vignetting_strength: float = 0.25, gradient: float = 0.0, gradient_angle: float = 0.0,
               exposure: float = 1.0) -> np.ndarray:
        """Optical blur (`blur_sigma`, with the corrections of the module), uneven lighting,
        sensor noise, quantisation -> uint8 (H, W).

        Lighting multiplies by the camera's vignetting and by a linear gradient of relative
        amplitude `gradient` (over the image width) in direction `gradient_angle` (rad), and
        by `exposure`. Noise: read noise of std `noise` grey levels plus shot noise whose
        variance grows linearly with brightness (equal to the read noise variance at 255)."""
        # In place on one image buffer and one scratch buffer: the same float32 operations in
        # the same order as the expressions in the comments, so the same image.
        if self.blur_sigma > 0:
            img = cv2.GaussianBlur(self.canvas, (0, 0), self.blur_sigma, borderType=cv2.BORDER_REPLICATE)
        else:
            img = self.canvas.copy()
        if self._after_blur is not None:
            img += self._after_blur
        cam = self.camera
        light = vignetting(cam, vignetting_strength)
        if gradient:
            gx = np.cos(gradient_angle) * gradient / cam.width
            gy = np.sin(gradient_angle) * gradient / cam.width
            xs = (np.arange(cam.width, dtype=np.float32) - cam.cx) * np.float32(gx)
            ys = (np.arange(cam.height, dtype=np.float32) - cam.cy) * np.float32(gy)
            light = np.multiply(light, np.add(1.0 + ys[:, None], xs[None, :]))   # light·(1 + ys + xs)
            light *= np.float32(exposure)
        else:
            light = light * np.float32(exposure)
        img *= light                                                              # img·(light·exposure)
        if noise > 0:
            if rng is None:
                raise ValueError("a random generator is needed for noise")
            # std = noise·√(1 + max(img, 0)/255); img + std·z, z standard normal
            std = np.maximum(img, 0.0, out=light)
            std *= np.float32(1.0 / 255.0)
            std += 1.0
            np.sqrt(std, out=std)
            std *= np.float32(noise)
            std *= standard_normal_image(rng, img.shape)
            img += std
        np.rint(img, out=img)
        np.clip(img, 0, 255, out=img)
        return img.astype(np.uint8)


def standard_normal_image(rng: np.random.Generator, shape: tuple[int, int]) -> np.ndarray:
    """Independent standard normal samples (float32, `shape`) that follow from `rng`'s state.

    OpenCV's generator (a Ziggurat over a multiply-with-carry stream) fills an image 4× faster
    than numpy's; it is seeded from `rng`, so the same generator state gives the same noise.
    Its state is the calling thread's own: this also reseeds OpenCV functions that use it
    later on the same thread (none of RoboCal's do)."""
    z = np.empty(shape, np.float32)
    cv2.setRNGSeed(int(rng.integers(2**31)))
    cv2.randn(z, 0.0, 1.0)
    return z


def _pixel_means(samples: np.ndarray, w: int, h: int) -> np.ndarray:
    """The mean of each pixel's s × s sub-samples ((h·s, w·s[, channels]) -> (h, w[, channels])):
    an area resize by a whole factor, which is that mean."""
    return cv2.resize(samples, (w, h), interpolation=cv2.INTER_AREA)


def _homography_row(H: np.ndarray, row: int, x: np.ndarray, y: np.ndarray, scratch: np.ndarray) -> np.ndarray:
    """H[row, 0]·x + H[row, 1]·y + H[row, 2] in a new array, in x's precision (`scratch`: a
    buffer like x, overwritten)."""
    out = np.multiply(x, H[row, 0])
    out += np.multiply(y, H[row, 1], out=scratch)
    out += H[row, 2]
    return out


def _gradient_norm(P: np.ndarray, H: np.ndarray, row: int, den_x: np.ndarray, den_y: np.ndarray, *,
                   out: np.ndarray, scratch: np.ndarray) -> np.ndarray:
    """hypot((H[row, 0] − P·H[2, 0]) / den_x, (H[row, 1] − P·H[2, 1]) / den_y) in `out`
    (`scratch`: a buffer like it, overwritten)."""
    a = np.multiply(P, H[2, 0], out=out)
    np.subtract(H[row, 0], a, out=a)
    a /= den_x
    b = np.multiply(P, H[2, 1], out=scratch)
    np.subtract(H[row, 1], b, out=b)
    b /= den_y
    return np.hypot(a, b, out=a)


def _apply_homography(rays: np.ndarray, H: np.ndarray):
    """(…, 2) float32 points through a 3x3 homography -> (X, Y, ok) float32 (ok: in front)."""
    x, y = np.ascontiguousarray(rays[..., 0]), np.ascontiguousarray(rays[..., 1])
    H = H.astype(np.float32)
    tmp = np.empty_like(x)
    den = _homography_row(H, 2, x, y, tmp)
    ok = den > 0
    den[~ok] = 1.0
    inv = np.divide(np.float32(1.0), den, out=den)  # 1 / np.where(ok, den, 1)
    X = _homography_row(H, 0, x, y, tmp)
    X *= inv
    Y = _homography_row(H, 1, x, y, tmp)
    Y *= inv
    return X, Y, ok


def _edge_coverage(d: np.ndarray, c: np.ndarray, s: np.ndarray) -> np.ndarray:
    """Fraction of a unit pixel on the inner side of a straight edge at signed distance `d` (px,
    + inside) from its centre, the edge's normal being (c, s) (|components|): the distribution
    of the normal coordinate over the pixel is a trapezoid, the box of width c convolved with
    the box of width s, and the coverage is its cumulative distribution at d."""
    a = np.maximum(c, s)
    b = np.maximum(np.minimum(c, s), 1e-9)
    lo, mid, hi = -(a + b) / 2, -(a - b) / 2, (a - b) / 2
    return np.select([d <= lo, d <= mid, d <= hi, d < -lo],
                     [0.0, (d - lo) ** 2 / (2 * a * b), (d + a / 2) / a, 1.0 - (-lo - d) ** 2 / (2 * a * b)],
                     1.0)


def _psi1(z: np.ndarray) -> np.ndarray:
    """∫ Φ: the first antiderivative of the normal CDF."""
    return z * ndtr(z) + np.exp(-0.5 * z * z) / _SQRT_2PI


def _psi2(z: np.ndarray) -> np.ndarray:
    """∫∫ Φ: its second antiderivative."""
    return 0.5 * ((z * z + 1.0) * ndtr(z) + z * np.exp(-0.5 * z * z) / _SQRT_2PI)


def _blurred_edge_coverage(d: np.ndarray, c: np.ndarray, s: np.ndarray, sigma: float) -> np.ndarray:
    """`_edge_coverage` of the edge blurred by a Gaussian of `sigma` px before the pixel
    integrates it: the normal CDF at d/sigma averaged over the trapezoid of the pixel footprint
    (second differences of ∫∫Φ; first differences of ∫Φ where the trapezoid is a box)."""
    if sigma <= 0:
        return _edge_coverage(d, c, s)
    a = np.maximum(c, s)
    b = np.minimum(c, s)
    out = np.empty_like(d)
    box = b < 1e-2                       # an edge along a pixel axis: the trapezoid is a box
    db, ab = d[box], a[box]
    out[box] = sigma * (_psi1((db + ab / 2) / sigma) - _psi1((db - ab / 2) / sigma)) / ab
    dt, at, bt = d[~box], a[~box], b[~box]
    out[~box] = sigma * sigma * (_psi2((dt + (at + bt) / 2) / sigma) - _psi2((dt + (at - bt) / 2) / sigma)
                                 - _psi2((dt - (at - bt) / 2) / sigma) + _psi2((dt - (at + bt) / 2) / sigma)) / (at * bt)
    return np.clip(out, 0.0, 1.0)


def _checker_axis(u: np.ndarray, g: np.ndarray, sq: float, count: int, margin: float):
    """Per-axis box-filter coverages at board coordinate u (mm) with |grad u| = g (mm/px).

    Returns (even, odd, board): the fraction of the pixel footprint along this axis covered
    by even-index squares, odd-index squares (squares −1..count−1, i.e. the checkered area),
    and by the whole board including its margin."""
    fu = u / sq
    k = np.add(fu, 0.5)
    np.floor(k, out=k)                         # nearest grid line
    c = np.subtract(fu, k, out=fu)             # signed distance to it, px (+: square k side):
    c *= sq                                    # d = (fu − k)·sq / g
    c = _coverage(c, g)                        # coverage of square k (right of the line)
    right_in = (k >= -1) & (k <= count - 1)
    left_in = (k >= 0) & (k <= count)          # k − 1 in −1 … count − 1 (k a whole number)
    half = np.multiply(k, 0.5, out=k)
    k_even = np.floor(half) == half            # (k % 2) == 0, without the slow float modulo
    right = np.where(right_in, c, 0.0)         # square k's share, if it is on the board
    left = np.subtract(1.0, c, out=c)          # square k − 1's share
    left[~left_in] = 0.0
    even = np.where(k_even, right, left)
    odd = np.where(k_even, left, right)
    lo = -(1.0 + margin) * sq
    hi = (count + margin) * sq
    board = _coverage(np.subtract(u, lo, out=right), g)    # clip(0.5 + (u − lo)/g, 0, 1)
    board *= _coverage(np.subtract(hi, u, out=left), g)     # · clip(0.5 + (hi − u)/g, 0, 1)
    return even, odd, board


def _coverage(d: np.ndarray, g: np.ndarray) -> np.ndarray:
    """clip(0.5 + d/g, 0, 1), in place on d: how much of a pixel lies beyond an edge at signed
    distance d (in the units of g, the length of a pixel there)."""
    d /= g
    d += 0.5
    return np.clip(d, 0.0, 1.0, out=d)
