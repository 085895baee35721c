"""Marker training: from an image of the marker to what detection needs.

`train_marker(image, outline=None, outer_size=40.0)` finds the marker's outer black square
(or takes its 4 corners), fits its edges to sub-pixel accuracy (core.marker.edges), takes the
reference point as the intersection of the diagonals (the square's centre), measures the clean
dark band inside each side and the bright border outside it (they bound the edge fit later),
and computes SIFT keypoints and descriptors (cv2.SIFT_create) of the marker area.

A marker with too little texture is refused with the reason: SIFT needs corners and
asymmetric shapes to find the marker in a scene and to tell its orientation.

A trained marker is saved as one `.npz` file (format robocal.trained_marker/1, see
docs/file-formats.md, section "Trained marker").
"""
from __future__ import annotations

import io
import zipfile
from dataclasses import dataclass, field
from pathlib import Path

import cv2
import numpy as np

from core.errors import RoboCalError
from core.images import to_gray8
from core.files import atomic_write_bytes
from core.marker.edges import EdgeOptions, OutlineFit, fit_outline
from core.marker.geometry import (expand_quad, is_convex, line_through, order_corners,
                                  side_lengths, signed_area)
from core.task import Monitor

FORMAT_FAMILY = "robocal.trained_marker"
FORMAT_MAJOR = 1
FORMAT = f"{FORMAT_FAMILY}/{FORMAT_MAJOR}"
MIN_FEATURES = 40
DEFAULT_OUTER_SIZE = 40.0      # mm, the shipped marker's outer square


def sift_detector() -> cv2.SIFT:
    """The SIFT detector used for training and detection (OpenCV defaults)."""
    return cv2.SIFT_create()


@dataclass(eq=False)
class TrainedMarker:
    """Everything detection needs to know about the marker.

    Training-image pixels use the pixel-centre convention. `outline` is the outer square,
    clockwise from the top-left corner; `reference_px` the intersection of its diagonals.
    `inner_band` / `outer_border` (4,) are the widths of the clean dark band inside and of the
    bright border outside each side, as fractions of that side's length."""

    name: str
    image: np.ndarray                  # (H, W) uint8 training image
    outline: np.ndarray                # (4, 2) px
    reference_px: np.ndarray           # (2,) px
    outer_size: float                  # mm, side of the outer square
    keypoint_xy: np.ndarray            # (N, 2) px
    keypoint_size: np.ndarray          # (N,)
    keypoint_angle: np.ndarray         # (N,) deg
    keypoint_response: np.ndarray      # (N,)
    keypoint_octave: np.ndarray        # (N,) int
    descriptors: np.ndarray            # (N, 128) float32
    keypoint_view: np.ndarray          # (N,) int: 0 the image itself, k > 0 the k-th simulated tilted view
    inner_band: np.ndarray             # (4,)
    outer_border: np.ndarray           # (4,)
    dark_level: float = 0.0
    bright_level: float = 255.0
    outline_sigma_px: float = 0.0      # predicted accuracy of the fitted outline corners
    source: str = ""
    _kp_cache: list | None = field(default=None, repr=False)

    @property
    def n_features(self) -> int:
        """All features, those of the simulated tilted views included."""
        return int(len(self.keypoint_xy))

    @property
    def n_image_features(self) -> int:
        """Features of the training image itself (view 0)."""
        return int(np.count_nonzero(self.keypoint_view == 0))

    @property
    def image_size(self) -> tuple[int, int]:
        return (int(self.image.shape[1]), int(self.image.shape[0]))

    @property
    def px_per_mm(self) -> float:
        return float(side_lengths(self.outline).mean() / self.outer_size)

    def keypoints(self) -> list:
        """The keypoints of the training image itself (view 0) as cv2.KeyPoint objects."""
        if self._kp_cache is None:
            own = self.keypoint_view == 0
            self._kp_cache = [cv2.KeyPoint(float(x), float(y), float(s), float(a), float(r), int(o))
                              for (x, y), s, a, r, o in zip(self.keypoint_xy[own], self.keypoint_size[own],
                                                            self.keypoint_angle[own], self.keypoint_response[own],
                                                            self.keypoint_octave[own])]
        return self._kp_cache

    def outline_mm(self) -> np.ndarray:
        """(4, 3) outer-square corners in the marker plate frame (mm): origin at the reference
        point, x to the right of the training image, y up, z out of the face."""
        s = self.outer_size / 2.0
        return np.array([[-s, s, 0.0], [s, s, 0.0], [s, -s, 0.0], [-s, -s, 0.0]])


    # -- file -------------------------------------------------------------------------------
    def to_bytes(self) -> bytes:
        kp = np.column_stack([self.keypoint_xy, self.keypoint_size, self.keypoint_angle,
                              self.keypoint_response, self.keypoint_octave, self.keypoint_view]).astype(np.float64)
        buf = io.BytesIO()
        np.savez_compressed(
            buf, format=np.array(FORMAT), name=np.array(self.name), image=self.image,
            outline=self.outline, reference_px=self.reference_px, outer_size=np.array(self.outer_size),
            keypoints=kp.reshape(-1, 7), descriptors=self.descriptors.astype(np.float32),
            inner_band=self.inner_band, outer_border=self.outer_border,
            levels=np.array([self.dark_level, self.bright_level]),
            outline_sigma_px=np.array(self.outline_sigma_px))
        return buf.getvalue()

    def save(self, path: str | Path) -> Path:
        """Write the trained marker as one .npz file (atomically)."""
        return atomic_write_bytes(path, self.to_bytes())

    @classmethod
    def load(cls, path: str | Path) -> "TrainedMarker":
        path = Path(path)
        try:
            with np.load(path, allow_pickle=False) as z:
                data = {k: z[k] for k in z.files}
        except FileNotFoundError as exc:
            raise RoboCalError("file not found", source=path, hint="Check the path.") from exc
        except (OSError, ValueError, EOFError, zipfile.BadZipFile) as exc:   # also a truncated file
            raise RoboCalError("not a trained-marker file (.npz), or a truncated one", source=path,
                               hint="Train the marker again (robocal locate accepts the training image).") from exc
        tag = str(data.get("format", ""))
        family, _, major = tag.partition("/")
        if family != FORMAT_FAMILY:
            raise RoboCalError(f"this is not a trained marker (format {tag!r})", source=path, field="format")
        if major.split(".")[0] != str(FORMAT_MAJOR):
            raise RoboCalError(f"unknown format version {major} (this RoboCal reads version {FORMAT_MAJOR})",
                               source=path, field="format", hint="Train the marker again with this release.")
        try:
            kp = np.asarray(data["keypoints"], dtype=float).reshape(-1, 7)
            levels = np.asarray(data["levels"], dtype=float)
            return cls(name=str(data["name"]), image=np.asarray(data["image"], dtype=np.uint8),
                       outline=np.asarray(data["outline"], dtype=float).reshape(4, 2),
                       reference_px=np.asarray(data["reference_px"], dtype=float).reshape(2),
                       outer_size=float(data["outer_size"]), keypoint_xy=kp[:, :2], keypoint_size=kp[:, 2],
                       keypoint_angle=kp[:, 3], keypoint_response=kp[:, 4],
                       keypoint_octave=kp[:, 5].astype(int), keypoint_view=kp[:, 6].astype(int),
                       descriptors=np.asarray(data["descriptors"], dtype=np.float32).reshape(-1, 128),
                       inner_band=np.asarray(data["inner_band"], dtype=float).reshape(4),
                       outer_border=np.asarray(data["outer_border"], dtype=float).reshape(4),
                       dark_level=float(levels[0]), bright_level=float(levels[1]),
                       outline_sigma_px=float(data.get("outline_sigma_px", 0.0)), source=str(path))
        except KeyError as exc:
            raise RoboCalError(f"missing entry {exc.args[0]!r}", source=path,
                               hint="Train the marker again.") from exc
        except (ValueError, TypeError, IndexError) as exc:       # an entry of the wrong shape or type
            raise RoboCalError(f"an entry has the wrong shape or type ({exc})", source=path,
                               hint="Train the marker again.") from exc


# -- outline ----------------------------------------------------------------------------------

def find_outline(image: np.ndarray) -> np.ndarray:
    """The largest dark convex quadrilateral not touching the image border: the marker's outer
    square, (4, 2) px clockwise from the top-left corner (about ±1 px; refined later)."""
    img = to_gray8(image)
    h, w = img.shape
    blur = cv2.GaussianBlur(img, (0, 0), 1.0)
    _, dark = cv2.threshold(blur, 0, 255, cv2.THRESH_BINARY_INV | cv2.THRESH_OTSU)
    contours, hierarchy = cv2.findContours(dark, cv2.RETR_CCOMP, cv2.CHAIN_APPROX_SIMPLE)
    best, best_area = None, 0.0
    if hierarchy is not None:
        for c, hier in zip(contours, hierarchy[0]):
            if hier[3] != -1:          # a hole, not the outer boundary of a dark region
                continue
            x, y, cw, ch = cv2.boundingRect(c)
            if x <= 1 or y <= 1 or x + cw >= w - 1 or y + ch >= h - 1:
                continue
            area = cv2.contourArea(c)
            if area < 0.004 * h * w or area <= best_area:
                continue
            approx = cv2.approxPolyDP(c, 0.03 * cv2.arcLength(c, True), True).reshape(-1, 2)
            if len(approx) != 4 or not is_convex(approx):
                continue
            hull_fill = area / max(cv2.contourArea(approx.astype(np.float32)), 1e-9)
            if hull_fill < 0.85:
                continue
            best, best_area = approx, area
    if best is None:
        raise RoboCalError("no dark square outline found in the training image",
                           hint="Show the whole marker (its black outer square on a bright plate, away from "
                                "the image border), or give the outline's 4 corners.")
    # contour pixels lie on the dark side: move half a pixel outwards
    quad = order_corners(best.astype(float))
    return expand_quad(quad, 1.0 + 0.5 / max(float(side_lengths(quad).mean()) / 2.0, 1.0))


def _run_lengths(img: np.ndarray, quad: np.ndarray, inward: bool, threshold: float, limit: float) -> np.ndarray:
    """Per side: a low percentile of the distance from the edge until the grey level crosses
    `threshold` (inward: rises above, outward: falls below), sampled along the side."""
    h, w = img.shape
    out = np.zeros(4)
    steps = np.arange(0.5, limit, 0.5)
    for k in range(4):
        c0, c1 = quad[k], quad[(k + 1) % 4]
        n = line_through(c0, c1)[:2]
        direction = -n if inward else n
        s = np.linspace(0.15, 0.85, 41)[:, None]
        base = c0 + s * (c1 - c0)
        pts = base[:, None, :] + steps[None, :, None] * direction[None, None, :]
        mx = pts[..., 0].astype(np.float32)
        my = pts[..., 1].astype(np.float32)
        vals = cv2.remap(img.astype(np.float32), mx, my, cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT,
                         borderValue=-1.0)
        # the first 1.5 px are the edge itself
        start = int(np.searchsorted(steps, 1.5))
        lengths = []
        for row in vals:
            r = row[start:]
            bad = (r > threshold) if inward else ((r < threshold) | (r < 0))
            idx = int(np.argmax(bad)) if bad.any() else len(r)
            lengths.append(steps[start + idx - 1] if idx > 0 else steps[start])
        out[k] = float(np.percentile(lengths, 10))
    return out


def train_marker(image: np.ndarray, outline=None, *, outer_size: float = DEFAULT_OUTER_SIZE, name: str = "marker",
                 min_features: int = MIN_FEATURES, tilted_views: bool = True, source: str = "", progress=None,
                 cancelled=None) -> TrainedMarker:
    """Train the marker from a grayscale (or BGR) uint8 image of it.

    `outline`: the outer square's 4 corners (px, any order), or None to find it as the largest
    dark quadrilateral. `outer_size`: the side of the outer square in mm. Raises RoboCalError
    when the image shows no usable square or gives SIFT too few features."""
    monitor = Monitor(progress, cancelled)
    img = to_gray8(image)
    if min(img.shape) < 48:
        raise RoboCalError(f"the training image is only {img.shape[1]}x{img.shape[0]} px",
                           hint="Use an image where the marker is at least 100 px wide.")
    if not outer_size > 0:
        raise RoboCalError(f"the marker size must be positive, got {outer_size} mm")
    monitor.step(0.0, "finding the outer square")
    quad = find_outline(img) if outline is None else order_corners(np.asarray(outline, dtype=float))
    if signed_area(quad) <= 0 or not is_convex(quad):
        raise RoboCalError("the outline corners do not form a convex quadrilateral",
                           hint="Give the 4 corners of the outer black square.")
    side = side_lengths(quad)
    if side.min() < 24:
        raise RoboCalError(f"the marker is only {side.min():.0f} px wide in the training image",
                           hint="Use an image where the marker is at least 100 px wide.")
    # grey levels: the dark band just inside the edges and the bright border just outside
    inner_probe = expand_quad(quad, 0.95)
    outer_probe = expand_quad(quad, 1.05)
    mask_in = np.zeros(img.shape, np.uint8)
    cv2.fillConvexPoly(mask_in, np.round(quad).astype(np.int32), 255)
    cv2.fillConvexPoly(mask_in, np.round(inner_probe).astype(np.int32), 0)
    mask_out = np.zeros(img.shape, np.uint8)
    cv2.fillConvexPoly(mask_out, np.round(outer_probe).astype(np.int32), 255)
    cv2.fillConvexPoly(mask_out, np.round(expand_quad(quad, 1.01)).astype(np.int32), 0)
    dark = float(np.median(img[mask_in > 0])) if np.any(mask_in) else 0.0
    bright = float(np.median(img[mask_out > 0])) if np.any(mask_out) else 255.0
    if bright - dark < 30:
        raise RoboCalError(f"the outer square is not darker than its border (contrast {bright - dark:.0f} grey levels)",
                           hint="The marker needs a black outer square on a bright plate.")
    mid = 0.5 * (dark + bright)
    limit = 0.45 * float(side.mean())
    inner = _run_lengths(img, quad, True, mid, limit)
    outer = _run_lengths(img, quad, False, bright - 0.25 * (bright - dark), limit)
    monitor.step(0.3, "fitting the edges")
    # a light symmetric blur moves no edge and gives a perfectly sharp (drawn) image a
    # measurable edge profile
    soft = cv2.GaussianBlur(img, (0, 0), 0.8)
    fit: OutlineFit = fit_outline(soft, quad, None, inner_px=inner, outer_px=outer,
                                  options=EdgeOptions(attribution_tolerance=3.0))
    if not fit.ok:
        raise RoboCalError(f"cannot fit the marker's outer square in the training image: {fit.reason}",
                           hint="Use a sharp, evenly lit image showing the whole marker with a bright border.")
    quad = fit.corners
    side = side_lengths(quad)
    inner_frac = inner / side
    outer_frac = outer / side
    monitor.step(0.4, "SIFT features")
    region = expand_quad(quad, 1.08).astype(np.float32)
    kps, desc = sift_detector().detectAndCompute(img, None)
    keep = [i for i, k in enumerate(kps) if cv2.pointPolygonTest(region, k.pt, False) >= 0]
    if len(keep) < min_features:
        raise RoboCalError(f"only {len(keep)} SIFT features on the marker (at least {min_features} needed); "
                           "the marker needs more texture: use a pattern with corners and asymmetric shapes",
                           hint="The default marker (resources/markers/default.png) gives about 200.")
    xy = [np.array([kps[i].pt for i in keep], dtype=float)]
    info = [np.array([[kps[i].size, kps[i].angle, kps[i].response, kps[i].octave, 0] for i in keep], dtype=float)]
    descs = [np.asarray(desc[keep], dtype=np.float32)]
    views = simulated_views() if tilted_views else []
    for v, A in enumerate(views, start=1):
        monitor.step(0.4 + 0.6 * v / (len(views) + 1), f"SIFT features of tilted view {v}/{len(views)}")
        vxy, vinfo, vdesc = _view_features(img, A, region)
        if len(vxy):
            info_v = vinfo.copy()
            info_v[:, 4] = v
            xy.append(vxy)
            info.append(info_v)
            descs.append(vdesc)
    xy_all = np.concatenate(xy)
    info_all = np.concatenate(info)
    monitor.step(1.0, "trained")
    return TrainedMarker(
        name=name, image=img.copy(), outline=quad, reference_px=fit.reference.copy(), outer_size=float(outer_size),
        keypoint_xy=xy_all, keypoint_size=info_all[:, 0], keypoint_angle=info_all[:, 1],
        keypoint_response=info_all[:, 2], keypoint_octave=info_all[:, 3].astype(int),
        keypoint_view=info_all[:, 4].astype(int), descriptors=np.concatenate(descs), inner_band=inner_frac, outer_border=outer_frac, dark_level=dark, bright_level=bright,
        outline_sigma_px=fit.sigma_px, source=source)


def simulated_views() -> list[tuple[float, float]]:
    """(tilt t = 1/cos(angle), longitude φ in degrees) of the simulated views: t = √2 and 2
    (45° and 60°), φ in steps of 72°/t, as ASIFT samples them."""
    out = []
    for t in (np.sqrt(2.0), 2.0):
        for phi in np.arange(0.0, 180.0 - 1e-6, 72.0 / t):
            out.append((float(t), float(phi)))
    return out


def _view_features(img: np.ndarray, view: tuple[float, float], region: np.ndarray):
    """SIFT features of a simulated tilted view (rotate by φ, blur and compress x by t, as
    ASIFT), with positions mapped back to the training image."""
    t, phi = view
    h, w = img.shape
    R = cv2.getRotationMatrix2D((0.0, 0.0), phi, 1.0)
    corners = np.array([[0, 0, 1], [w - 1, 0, 1], [w - 1, h - 1, 1], [0, h - 1, 1]], dtype=float) @ R.T
    lo = corners.min(axis=0)
    R[:, 2] -= lo
    size = np.ceil(corners.max(axis=0) - lo).astype(int) + 1
    rotated = cv2.warpAffine(img, R, (int(size[0]), int(size[1])), flags=cv2.INTER_LINEAR,
                             borderMode=cv2.BORDER_REPLICATE)
    blurred = cv2.GaussianBlur(rotated, (0, 1), sigmaX=0.8 * np.sqrt(t * t - 1.0), sigmaY=0.0)
    new_w = max(int(round(size[0] / t)), 16)
    viewed = cv2.resize(blurred, (new_w, int(size[1])), interpolation=cv2.INTER_LINEAR)
    kps, desc = sift_detector().detectAndCompute(viewed, None)
    if not kps:
        return np.zeros((0, 2)), np.zeros((0, 5)), np.zeros((0, 128), np.float32)
    pts = np.array([k.pt for k in kps], dtype=float)
    fx = size[0] / new_w
    rot = np.column_stack([(pts[:, 0] + 0.5) * fx - 0.5, pts[:, 1]])
    back = (rot - R[:, 2]) @ np.linalg.inv(R[:, :2]).T
    keep = np.array([cv2.pointPolygonTest(region, (float(x), float(y)), False) >= 0 for x, y in back], dtype=bool)
    info = np.array([[k.size, k.angle, k.response, k.octave, 0] for k in kps], dtype=float)
    return back[keep], info[keep], np.asarray(desc, np.float32)[keep]


def train_from_description(description, *, min_features: int = MIN_FEATURES) -> TrainedMarker:
    """Train from a marker description (core.marker.description): its png and its corners."""
    img = description.load_image()
    return train_marker(img, description.outer_corners_px, outer_size=description.outer_size,
                        name=description.name, min_features=min_features,
                        source=str(description.image_path))


