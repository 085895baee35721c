"""Marker detection in one image: SIFT finds the marker area, Canny edges the reference point.

Area (`find_marker_area`):
  SIFT keypoints of the scene (first on the half-size image, which is 4x faster and enough
  for the marker at 0.5–4 px/mm; on the full image when that finds nothing), each matched to
  its two nearest training descriptors with Lowe's ratio test (scene → marker, so that two
  copies of the marker both match), a RANSAC (MAGSAC) homography training image → scene,
  then SIFT again at full resolution in the region of interest only to refine it. The scene
  is rejected, with the reason, when too few matches agree (no marker), when a second
  consistent cluster of matches at eight or more different places remains after removing the
  first (two marker-like objects; repeats of one correspondence count once),
  when the homography is implausible (mirrored, folded, degenerate), and when the marker with
  its border is not wholly inside the image.
Reference point (`detect_marker`): core.marker.edges.fit_outline on the region of interest,
  seeded by the homography's outline.

`detect_marker(..., predicted=H)` skips SIFT altogether (tracking mode); `search_roi=` runs
SIFT on that region only.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field

import cv2
import numpy as np

from core.camera import PixelMap
from core.images import to_gray8
from core.marker.edges import EdgeOptions, OutlineFit, fit_outline
from core.marker.geometry import (bounding_box, expand_quad, inside_image, is_convex, line_through,
                                  map_points, side_lengths, signed_area)
from core.marker.training import TrainedMarker, sift_detector


@dataclass
class DetectionOptions:
    ratio: float = 0.8                  # Lowe's ratio test
    min_inliers: int = 10               # consistent matches needed to accept the marker
    second_min_inliers: int = 8         # ... and to call a second cluster a second marker
    ransac_threshold: float = 3.0       # px (full resolution)
    half_resolution: bool = True        # first pass on the half-size image
    roi_refine: bool = True             # refine the homography with full-resolution SIFT in the ROI
    min_spread: float = 0.15            # inliers must span this fraction of the marker's area
    min_size_px: float = 14.0           # smallest side of the outer square in the image
    max_side_ratio: float = 6.0         # longest / shortest side (foreshortening)
    edge: EdgeOptions = field(default_factory=EdgeOptions)


@dataclass
class AreaDetection:
    """The SIFT stage (what the GUI draws: keypoints, matches, inliers, outline, ROI)."""

    ok: bool
    reason: str = ""
    image_size: tuple[int, int] = (0, 0)
    mode: str = ""                          # "half", "full", "roi" (SIFT) or "predicted" (no SIFT)
    keypoints: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))      # scene px, all passes
    match_scene: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))    # (M, 2) scene px, last pass
    match_train: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))    # (M, 2) training px
    inliers: np.ndarray = field(default_factory=lambda: np.zeros(0, bool))       # (M,)
    homography: np.ndarray | None = None    # 3x3, training px -> scene px
    outline: np.ndarray | None = None       # (4, 2) predicted outer square, scene px
    roi: tuple[int, int, int, int] = (0, 0, 0, 0)
    sift_reference: np.ndarray | None = None   # the training reference point through the homography
    second_outline: np.ndarray | None = None   # a second marker-like object, when found
    sift_seconds: float = 0.0

    @property
    def n_matches(self) -> int:
        return int(len(self.match_scene))

    @property
    def n_inliers(self) -> int:
        return int(np.count_nonzero(self.inliers))


@dataclass
class MarkerDetection:
    """Marker found in one image: area (SIFT) and reference point (Canny + edge fit).

    `reference` is in raw image pixels, `reference_ideal` in the pixel map's ideal pixels
    (undistorted, possibly rectified), `reference_cov` its covariance there (px²)."""

    ok: bool
    reason: str = ""
    stage: str = ""                         # where it failed: "area" or "reference"
    area: AreaDetection | None = None
    outline: OutlineFit | None = None
    timings: dict = field(default_factory=dict)

    @property
    def reference(self) -> np.ndarray | None:
        return self.outline.reference if self.ok else None

    @property
    def reference_ideal(self) -> np.ndarray | None:
        return self.outline.reference_ideal if self.ok else None

    @property
    def reference_cov(self) -> np.ndarray | None:
        return self.outline.reference_cov if self.ok else None

    @property
    def sigma_px(self) -> float:
        return self.outline.sigma_px if self.ok else float("nan")

    @property
    def corners(self) -> np.ndarray | None:
        return self.outline.corners if self.ok else None

    @property
    def sift_reference(self) -> np.ndarray | None:
        return None if self.area is None else self.area.sift_reference

    @property
    def homography(self) -> np.ndarray | None:
        return None if self.area is None else self.area.homography


# -- SIFT -------------------------------------------------------------------------------------

def _matcher():
    """A brute-force L2 matcher (one per call: cheap, and safe on worker threads)."""
    return cv2.BFMatcher(cv2.NORM_L2)


def sift_features(image: np.ndarray, *, half: bool = False, roi=None) -> tuple[np.ndarray, np.ndarray | None]:
    """SIFT keypoint positions (N, 2, scene px) and descriptors of the image (or its half-size
    version, or a region (x0, y0, x1, y1) of it)."""
    x0 = y0 = 0
    img = image
    if roi is not None:
        x0, y0, x1, y1 = roi
        img = image[y0:y1, x0:x1]
    if half:
        img = cv2.pyrDown(img)
    if img.size == 0 or min(img.shape) < 16:
        return np.zeros((0, 2)), None
    kps, desc = sift_detector().detectAndCompute(img, None)
    if not kps:
        return np.zeros((0, 2)), None
    xy = np.array([k.pt for k in kps], dtype=float)
    if half:
        xy = 2.0 * xy + 0.5          # half-size pixel i covers full pixels 2i and 2i + 1
    return xy + [x0, y0], desc


def match_to_marker(trained: TrainedMarker, desc: np.ndarray | None, ratio: float) -> tuple[np.ndarray, np.ndarray]:
    """(scene indices, training indices) of the scene features passing Lowe's ratio test.

    The second-best neighbour counted by the test is the nearest one at another place of the
    marker: the simulated tilted views hold several descriptors of the same physical point,
    which must not make each other ambiguous."""
    if desc is None or len(desc) == 0 or trained.n_features < 2:
        return np.zeros(0, int), np.zeros(0, int)
    k = min(5, trained.n_features)
    knn = _matcher().knnMatch(np.asarray(desc, np.float32), trained.descriptors, k=k)
    same = 0.03 * float(side_lengths(trained.outline).mean())
    xy = trained.keypoint_xy
    q, t = [], []
    for cand in knn:
        if not cand:
            continue
        best = cand[0]
        p0 = xy[best.trainIdx]
        second = None
        for m in cand[1:]:
            if np.hypot(*(xy[m.trainIdx] - p0)) > same:
                second = m
                break
        if second is None or best.distance < ratio * second.distance:
            q.append(best.queryIdx)
            t.append(best.trainIdx)
    return np.array(q, int), np.array(t, int)


def _homography(src: np.ndarray, dst: np.ndarray, threshold: float):
    if len(src) < 4:
        return None, np.zeros(len(src), bool)
    H, mask = cv2.findHomography(src.astype(np.float32), dst.astype(np.float32), cv2.USAC_MAGSAC, threshold,
                                 maxIters=2000, confidence=0.999)
    if H is None:
        return None, np.zeros(len(src), bool)
    inl = mask.ravel().astype(bool)
    if inl.sum() >= 6:
        H2, _ = cv2.findHomography(src[inl].astype(np.float64), dst[inl].astype(np.float64), 0)
        if H2 is not None:
            err = np.linalg.norm(map_points(H2, src) - dst, axis=1)
            inl = err <= threshold
            H = H2
    return H, inl


def plausibility(trained: TrainedMarker, H: np.ndarray, options: DetectionOptions) -> str:
    """'' when the homography gives a plausible view of the marker, else why not."""
    if H is None or not np.all(np.isfinite(H)):
        return "no consistent homography"
    outline = map_points(H, trained.outline)
    if not np.all(np.isfinite(outline)):
        return "the homography maps the marker to infinity"
    # every point of the marker must stay in front of the camera (same sign of w)
    w = np.hstack([trained.outline, np.ones((4, 1))]) @ H[2]
    if np.any(w * np.sign(w[0]) <= 0):
        return "the homography folds the marker"
    if signed_area(outline) <= 0:
        return "the matches give a mirrored marker"
    if not is_convex(outline):
        return "the matches give a non-convex outline"
    sides = side_lengths(outline)
    if sides.min() < options.min_size_px:
        return f"the marker would be only {sides.min():.0f} px wide"
    if sides.max() / sides.min() > options.max_side_ratio:
        return "the matches give an implausibly distorted outline"
    return ""


def inlier_spread(trained: TrainedMarker, train_pts: np.ndarray) -> float:
    """Area of the convex hull of the matched training points over the outline's area."""
    if len(train_pts) < 3:
        return 0.0
    hull = cv2.convexHull(np.asarray(train_pts, np.float32))
    return float(cv2.contourArea(hull)) / max(signed_area(trained.outline), 1e-9)


def _accept(trained: TrainedMarker, H, inl: np.ndarray, train: np.ndarray, opt: DetectionOptions) -> str:
    """'' when a homography and its inliers make a detection, else why not."""
    if H is None or inl.sum() < opt.min_inliers:
        return f"only {int(inl.sum()) if H is not None else 0} of {len(inl)} SIFT matches agree ({opt.min_inliers} needed)"
    why = plausibility(trained, H, opt)
    if why:
        return why
    if inlier_spread(trained, train[inl]) < opt.min_spread:
        return "the consistent SIFT matches cover only a small part of the marker"
    return ""


def band_widths(trained: TrainedMarker, H: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The clean dark band inside and the bright border outside each side, in scene px
    (the smallest along the side, through the homography)."""
    inner = np.zeros(4)
    outer = np.zeros(4)
    q = trained.outline
    L = side_lengths(q)
    for k in range(4):
        c0, c1 = q[k], q[(k + 1) % 4]
        n = line_through(c0, c1)[:2]
        s = np.array([0.1, 0.5, 0.9])[:, None]
        p = c0 + s * (c1 - c0)
        pin = p - n * trained.inner_band[k] * L[k]
        pout = p + n * trained.outer_border[k] * L[k]
        mp, mi, mo = map_points(H, p), map_points(H, pin), map_points(H, pout)
        inner[k] = float(np.linalg.norm(mi - mp, axis=1).min())
        outer[k] = float(np.linalg.norm(mo - mp, axis=1).min())
    return inner, outer


def _area_from_h(trained: TrainedMarker, H: np.ndarray, image_size, mode: str, **kw) -> AreaDetection:
    outline = map_points(H, trained.outline)
    _, outer = band_widths(trained, H)
    pad = float(min(outer.max(), 12.0)) + 6.0
    roi = bounding_box(outline, pad, image_size)
    ref = map_points(H, trained.reference_px[None])[0]
    return AreaDetection(True, "", image_size, mode, homography=H, outline=outline, roi=roi, sift_reference=ref,
                         **kw)


def first_of_each_pair(scene: np.ndarray, train: np.ndarray, tol_px: float = 0.5) -> np.ndarray:
    """Mask keeping one match per (scene point, training point) pair, both rounded to `tol_px`.

    SIFT gives one keypoint per dominant orientation at the same place, and the training image
    holds several descriptors of one marker point (its tilted views), so one correspondence can
    appear many times; repeated, four places would pass for a consistent cluster of ten."""
    if len(scene) == 0:
        return np.zeros(0, bool)
    key = np.round(np.hstack([scene, train]) / tol_px)
    _, first = np.unique(key, axis=0, return_index=True)
    keep = np.zeros(len(scene), bool)
    keep[first] = True
    return keep


def distinct_points(xy: np.ndarray, tol_px: float = 0.5) -> int:
    """How many different places (within `tol_px`) the points (N, 2) are at."""
    return 0 if len(xy) == 0 else len(np.unique(np.round(np.asarray(xy) / tol_px), axis=0))


def _overlaps(a: np.ndarray, b: np.ndarray) -> bool:
    ok, _ = cv2.intersectConvexConvex(a.astype(np.float32), b.astype(np.float32))
    return ok > 0


def find_marker_area(trained: TrainedMarker, image: np.ndarray, *, search_roi=None,
                     options: DetectionOptions | None = None) -> AreaDetection:
    """The SIFT stage: where the marker is (homography, outline, ROI) or why it is not found."""
    opt = options or DetectionOptions()
    img = to_gray8(image)
    size = (img.shape[1], img.shape[0])
    t_start = time.perf_counter()
    passes = []
    if search_roi is not None:
        passes.append(("roi", False, tuple(int(v) for v in search_roi)))
    else:
        if opt.half_resolution:
            passes.append(("half", True, None))
        passes.append(("full", False, None))
    found = None
    last = None
    for mode, half, roi in passes:
        xy, desc = sift_features(img, half=half, roi=roi)
        qi, ti = match_to_marker(trained, desc, opt.ratio)
        scene = xy[qi] if len(qi) else np.zeros((0, 2))
        train = trained.keypoint_xy[ti] if len(ti) else np.zeros((0, 2))
        thr = opt.ransac_threshold * (1.5 if half else 1.0)
        H, inl = _homography(train, scene, thr)
        why = _accept(trained, H, inl, train, opt)
        last = dict(mode=mode, keypoints=xy, match_scene=scene, match_train=train, inliers=inl, H=H, why=why)
        if not why:
            found = last
            break
    kw = dict(keypoints=last["keypoints"], match_scene=last["match_scene"], match_train=last["match_train"],
              inliers=last["inliers"])
    if found is None:
        reason = f"no marker found: {last['why']}"
        return AreaDetection(False, reason, size, last["mode"], sift_seconds=time.perf_counter() - t_start, **kw)
    H = found["H"]
    area = _area_from_h(trained, H, size, found["mode"], **kw)
    # a second marker-like object: a second consistent cluster among the remaining matches
    if search_roi is None:
        scene, train, inl = found["match_scene"], found["match_train"], found["inliers"]
        region = expand_quad(area.outline, 1.6).astype(np.float32)
        rest = ~inl & np.array([cv2.pointPolygonTest(region, (float(x), float(y)), False) < 0 for x, y in scene],
                               dtype=bool) if len(scene) else np.zeros(0, bool)
        rest &= first_of_each_pair(scene, train)
        if rest.sum() >= opt.second_min_inliers:
            H2, inl2 = _homography(train[rest], scene[rest], opt.ransac_threshold * (1.5 if found["mode"] == "half" else 1))
            if (H2 is not None and distinct_points(scene[rest][inl2]) >= opt.second_min_inliers
                    and not plausibility(trained, H2, opt)
                    and inlier_spread(trained, train[rest][inl2]) >= opt.min_spread):
                second = map_points(H2, trained.outline)
                if not _overlaps(second, area.outline):
                    area.ok = False
                    area.second_outline = second
                    area.reason = (f"two marker-like objects in view ({distinct_points(scene[inl])} and "
                                   f"{distinct_points(scene[rest][inl2])} "
                                   "consistent SIFT matches): cannot tell which one is the marker")
                    area.sift_seconds = time.perf_counter() - t_start
                    return area
    # refine at full resolution in the region of interest
    if opt.roi_refine and found["mode"] == "half":
        xy, desc = sift_features(img, roi=area.roi)
        qi, ti = match_to_marker(trained, desc, opt.ratio)
        if len(qi) >= opt.min_inliers:
            H2, inl2 = _homography(trained.keypoint_xy[ti], xy[qi], opt.ransac_threshold)
            if not _accept(trained, H2, inl2, trained.keypoint_xy[ti], opt):
                area = _area_from_h(trained, H2, size, "roi", keypoints=np.vstack([area.keypoints, xy]),
                                    match_scene=xy[qi], match_train=trained.keypoint_xy[ti], inliers=inl2)
    area.sift_seconds = time.perf_counter() - t_start
    return check_in_view(trained, area)


def check_in_view(trained: TrainedMarker, area: AreaDetection, margin: float = 1.0) -> AreaDetection:
    """Reject (in place) an area whose outer square, with the border the edge fit needs, is
    not wholly inside the image."""
    if not area.ok:
        return area
    _, outer = band_widths(trained, area.homography)
    need = expand_quad(area.outline, 1.0 + 2.0 * float(min(outer.min(), 4.0)) / max(side_lengths(area.outline).mean(), 1.0))
    if not inside_image(need, area.image_size, margin):
        area.ok = False
        area.reason = "the marker is partly outside the image"
    return area


def detect_marker(trained: TrainedMarker, image: np.ndarray, *, pixel_map: PixelMap | None = None,
                  predicted: np.ndarray | None = None, search_roi=None,
                  options: DetectionOptions | None = None) -> MarkerDetection:
    """Find the marker and its reference point in one image.

    `predicted`: a homography (training px -> scene px) from tracking; SIFT is skipped.
    `search_roi`: (x0, y0, x1, y1) to run SIFT there only. `pixel_map`: raw -> ideal pixels
    (the camera's undistortion, or a rectification) in which the edges are fitted."""
    opt = options or DetectionOptions()
    img = to_gray8(image)
    size = (img.shape[1], img.shape[0])
    t0 = time.perf_counter()
    if predicted is not None:
        H = np.asarray(predicted, dtype=float)
        why = plausibility(trained, H, opt)
        if why:
            return MarkerDetection(False, f"the predicted marker position is unusable: {why}", "area",
                                   AreaDetection(False, why, size, "predicted"))
        area = check_in_view(trained, _area_from_h(trained, H, size, "predicted"))
    else:
        area = find_marker_area(trained, img, search_roi=search_roi, options=opt)
    t1 = time.perf_counter()
    if not area.ok:
        return MarkerDetection(False, area.reason, "area", area, timings={"area": t1 - t0})
    inner, outer = band_widths(trained, area.homography)
    fit = fit_outline(img, area.outline, pixel_map, inner_px=inner, outer_px=outer, options=opt.edge)
    t2 = time.perf_counter()
    timings = {"area": t1 - t0, "reference": t2 - t1}
    if not fit.ok:
        return MarkerDetection(False, fit.reason, "reference", area, fit, timings)
    return MarkerDetection(True, "", "", area, fit, timings)
