"""The marker in 3D from a stereo pair: SIFT → Canny → SSD correlation → triangulation.

`MarkerLocator(trained, rectification).locate(left, right)`:

1. **Left image**: SIFT finds the marker area, Canny and the edge fit give the reference point
   to a few hundredths of a pixel, in rectified coordinates (core.marker.detection).
2. **SSD correlation** (eq. 26–27, core.marker.correspondence): a window the size of the marker,
   centred on the left reference point, slid along the same row of the rectified right image;
   the minimum of the criteria function gives the disparity (sub-pixel by a parabola fit,
   refined with the window warped by the marker's plane), its reliability (best /
   second-best minimum) rejects ambiguous matches, and d ≤ 0 is refused.
3. **Right image**: the SSD disparity tells where the marker is in the right image; SIFT in
   that region only and the same Canny chain give the right reference point.
4. **Checks**: both reference points, and each corner of the outer square, on the same
   rectified row (within `epipolar_tolerance`; a corner off its row means the outline was found
   differently in the two images, e.g. an edge partly covered), the four corners' disparities
   on one plane (within `max_corner_planarity`: an edge fitted through an occluder bends it),
   the edge disparity u_l − u_r within `disparity_tolerance` of the SSD one, and, when the
   marker size is known, the triangulated outer square as large as the trained one.
5. **Triangulation** (eq. 23–25, core.marker.triangulation.triangulate_rectified) of the left point
   with the disparity, and the general eq. (22) from the raw points as a cross-check; the
   covariance propagates the reference points' standard deviations (from the edge-fit
   residuals).

Which disparity is used (`LocatorOptions.method`), measured on the virtual lab (bench
`marker`: 120 pairs at 400–900 mm, tilted up to 60°, true rig):

- the chapter's combination, left reference point + SSD disparity ("ssd"): with the plain
  criteria of eq. (26) and a window the marker's size, a tilted marker seen from 130 mm
  apart looks different in the two views (more than a shift), so the minimum is biased by
  ~0.3 px and sometimes not the marker at all: median 3D error 0.67 mm, 46 of 120 points
  more than 1 mm off. With the window warped by the marker's plane (its normal from the left
  outline; `warp_window`, default) the SSD disparity is good to ~0.03 px: 3D RMS error
  0.035 mm;
- the reference points of both images ("edges", default): the right image's reference point
  comes from the same SIFT → Canny chain, in the region the SSD disparity points to; the
  disparity is u_l − u_r of the two points, and the SSD disparity must agree with it (the
  correspondence check): 3D RMS error 0.009 mm, a quarter of the SSD one;
- SIFT alone (homography-mapped centres in both images): 0.46 mm.

So "edges" is the default; SSD finds the marker in the right image, checks the match, gives
the reliability figure, and remains available as the chapter's method ("ssd"); both 3D
points are returned (`point`, `point_ssd`).

`MarkerTracker` (tracking mode) reuses the previous location's homographies, or a pose
predicted by the robot model, to skip SIFT and go straight to the edge fit; it falls back to
SIFT in a region around the prediction, then to a full (cold) search.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field

import cv2
import numpy as np

from core import transforms as tf
from core.marker.correspondence import (DEFAULT_MAX_MISMATCH, DEFAULT_MAX_RELIABILITY, Correspondence,
                                        WindowSweep, find_disparity, odd, window_sweep)
from core.errors import RoboCalError
from core.images import require_gray8
from core.marker.detection import DetectionOptions, MarkerDetection, detect_marker
from core.marker.geometry import bounding_box, expand_quad, map_points
from core.marker.orientation import MarkerOrientation, marker_orientation
from core.marker.training import TrainedMarker
from core.stereo.rectification import StereoRectification
from core.task import Monitor
from core.marker.triangulation import triangulate_general, triangulate_rectified


@dataclass
class LocatorOptions:
    detection: DetectionOptions = field(default_factory=DetectionOptions)
    method: str = "edges"                  # "edges" (both reference points) or "ssd" (chapter)
    window: tuple[int, int] | None = None  # SSD window (h, w); None: the marker's apparent size
    warp_window: bool = True               # refine SSD with the window warped by the marker plane
    max_window: int = 151                  # px, cap of the automatic window
    max_reliability: float = DEFAULT_MAX_RELIABILITY
    max_mismatch: float = DEFAULT_MAX_MISMATCH
    epipolar_tolerance: float = 1.0        # px, |v_left − v_right| of the reference points
    disparity_tolerance: float = 2.0       # px, |edge disparity − SSD disparity|
    # px: the four corner disparities off one plane (nominal ~0.01 px; an edge fitted through
    # part of an occluder: 0.1 px and more); None: not checked
    max_corner_planarity: float | None = 0.1
    max_size_error: float | None = 0.2     # relative; None: the marker size is not checked
    sigma_floor_px: float = 0.0            # added in quadrature to each reference point's sigma
    general_check: bool = True             # also triangulate with eq. (22) from the raw points (not when tracking)


@dataclass
class MarkerLocation:
    """One located marker (or why not), with everything the GUI draws.

    Points in mm in the left camera frame; image points in raw pixels (`left_point`,
    `right_point`) and rectified pixels (`left_rectified`, `right_rectified`)."""

    ok: bool
    reason: str = ""
    stage: str = ""                        # "left", "ssd", "right", "check", "triangulation"
    method: str = ""
    mode: str = "cold"                     # "cold" or "tracking"
    left: MarkerDetection | None = None
    right: MarkerDetection | None = None
    correspondence: Correspondence | None = None
    point: np.ndarray | None = None        # (3,) mm
    covariance: np.ndarray | None = None   # (3, 3) mm²
    point_ssd: np.ndarray | None = None    # the chapter's point: left reference + SSD disparity
    point_general: np.ndarray | None = None   # eq. (22) from the raw reference points
    left_point: np.ndarray | None = None
    right_point: np.ndarray | None = None
    left_rectified: np.ndarray | None = None
    right_rectified: np.ndarray | None = None
    disparity: float = float("nan")        # used for the point, px
    disparity_ssd: float = float("nan")
    disparity_edges: float = float("nan")
    epipolar_error: float = float("nan")   # v_left − v_right, px
    corner_planarity: float = float("nan") # px, largest corner disparity off the plane of all four
    sigma_px: float = float("nan")         # per-image reference point sigma used, px
    size_mm: float = float("nan")          # triangulated side of the outer square
    orientation: MarkerOrientation | None = None   # the marker frame from its 4 corners (core.marker.orientation)
    timings: dict = field(default_factory=dict)

    @property
    def sigma(self) -> np.ndarray | None:
        """Standard deviations along x, y, z (mm)."""
        return None if self.covariance is None else np.sqrt(np.diag(self.covariance))

    def to_dict(self) -> dict:
        """A JSON-able summary (robocal locate --json)."""
        def arr(v):
            return None if v is None else [float(x) for x in np.ravel(v)]

        def num(v):
            return None if v is None or not np.isfinite(v) else float(v)

        c = self.correspondence
        d = {"ok": self.ok, "reason": self.reason or None, "stage": self.stage or None, "method": self.method,
             "units": {"point": "mm, left camera frame", "image": "px"}}
        if self.point is not None:
            d.update(x=float(self.point[0]), y=float(self.point[1]), z=float(self.point[2]),
                     sigma=arr(self.sigma), covariance=np.asarray(self.covariance).tolist())
        d.update(left={"image_point": arr(self.left_point), "rectified": arr(self.left_rectified),
                       "sift_point": arr(self.left.sift_reference if self.left else None),
                       "sigma_px": num(self.left.sigma_px) if self.left and self.left.ok else None},
                 right={"image_point": arr(self.right_point), "rectified": arr(self.right_rectified),
                        "sift_point": arr(self.right.sift_reference if self.right else None),
                        "sigma_px": num(self.right.sigma_px) if self.right and self.right.ok else None},
                 disparity=num(self.disparity), disparity_ssd=num(self.disparity_ssd),
                 disparity_edges=num(self.disparity_edges), epipolar_error=num(self.epipolar_error),
                 corner_planarity=num(self.corner_planarity),
                 sigma_px=num(self.sigma_px), size_mm=num(self.size_mm),
                 point_ssd=arr(self.point_ssd), point_general=arr(self.point_general))
        if c is not None:
            d.update(criteria_minimum=num(c.minimum), reliability=num(c.reliability),
                     second_minimum=num(c.second_minimum), window=list(c.window),
                     sigma_disparity=num(c.sigma_disparity))
        d["orientation"] = None if self.orientation is None else self.orientation.to_dict()
        return d


def _reject(loc: MarkerLocation, stage: str, reason: str) -> MarkerLocation:
    loc.ok = False
    loc.stage = stage
    loc.reason = reason
    return loc


class MarkerLocator:
    """Locates the trained marker in stereo pairs of one calibrated rig."""

    def __init__(self, trained: TrainedMarker, rectification: StereoRectification,
                 options: LocatorOptions | None = None):
        self.trained = trained
        self.rect = rectification
        self.options = options or LocatorOptions()
        if self.options.method not in ("edges", "ssd"):
            raise ValueError(f"unknown method {self.options.method!r}")

    # -- helpers ------------------------------------------------------------------------------
    def _check_images(self, left, right):
        left, right = require_gray8(left), require_gray8(right)
        w, h = self.rect.image_size
        for name, img in (("left", left), ("right", right)):
            if img.shape != (h, w):
                raise RoboCalError(f"the {name} image is {img.shape[1]}x{img.shape[0]} px, the stereo "
                                   f"calibration is for {w}x{h}", hint="Use images of the calibrated cameras.")
        return left, right

    def _window(self, det: MarkerDetection) -> tuple[int, int]:
        if self.options.window is not None:
            return (odd(self.options.window[0]), odd(self.options.window[1]))
        c = det.outline.corners_ideal
        w = odd(min(np.ptp(c[:, 0]), self.options.max_window), 5)
        h = odd(min(np.ptp(c[:, 1]), self.options.max_window), 5)
        return (h, w)

    def predicted_homographies(self, pose: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Homographies training px -> raw px in both images for a marker pose (4x4, plate
        frame -> left camera frame, mm), e.g. from the robot model."""
        P = tf.transform_points(np.asarray(pose, dtype=float), self.trained.outline_mm())
        rig = self.rect.rig
        left = rig.left.project(P)
        right = rig.right.project(rig.to_right(P))
        src = self.trained.outline.astype(np.float32)
        return (cv2.getPerspectiveTransform(src, left.astype(np.float32)),
                cv2.getPerspectiveTransform(src, right.astype(np.float32)))

    # -- the pipeline -------------------------------------------------------------------------
    def locate(self, left: np.ndarray, right: np.ndarray, *, predicted: tuple | None = None,
               progress=None, cancelled=None) -> MarkerLocation:
        """The 3D reference point from a stereo pair, or a location with ok False and the reason.

        `predicted` (H_left, H_right): homographies training px -> raw px from tracking;
        SIFT is then skipped where the edge fit succeeds near them."""
        monitor = Monitor(progress, cancelled)
        opt = self.options
        t0 = time.perf_counter()
        left, right = self._check_images(left, right)
        loc = MarkerLocation(False, method=opt.method, mode="cold" if predicted is None else "tracking")
        monitor.step(0.0, "left image: SIFT and edges")
        det_l = self._detect(left, "left", None if predicted is None else predicted[0])
        loc.left = det_l
        t1 = time.perf_counter()
        loc.timings["left"] = t1 - t0
        if not det_l.ok:
            return _reject(loc, "left", f"left image: {det_l.reason}")
        loc.left_point = det_l.reference
        u_l, v_l = det_l.reference_ideal
        loc.left_rectified = np.array([u_l, v_l])
        monitor.step(0.4, "SSD correlation along the epipolar line")
        window = self._window(det_l)
        d_range = None
        if predicted is not None:
            # around the predicted disparity, wide enough for a second minimum to show
            ref_r = self.rect.right_map.to_ideal(map_points(predicted[1], self.trained.reference_px[None]))[0]
            d_pred = u_l - ref_r[0]
            half = max(1.0 * window[1], 40.0)
            d_range = (d_pred - half, d_pred + half)
        normal, guess = None, None
        n_candidates = 3 if predicted is None else 2
        if opt.warp_window:
            normal, centre = square_pose(det_l.outline.corners_ideal, self.rect.P1, self.trained.outer_size)
            guess = self.rect.disparity_of_depth(centre[2]) if centre[2] > 0 else None
        corr = find_disparity(self.rect, left, right, (u_l, v_l), window=window, d_range=d_range,
                              plane_normal=normal, disparity_guess=guess, max_reliability=opt.max_reliability,
                              max_mismatch=opt.max_mismatch, candidates=n_candidates)
        loc.correspondence = corr
        loc.disparity_ssd = corr.disparity
        t2 = time.perf_counter()
        loc.timings["ssd"] = t2 - t1
        if not corr.ok:
            return _reject(loc, "ssd", corr.reason)
        monitor.step(0.6, "right image: SIFT and edges")
        H_r = None if predicted is None else predicted[1]
        det_r = self._detect_right(right, det_l, corr, H_r)
        loc.right = det_r
        t3 = time.perf_counter()
        loc.timings["right"] = t3 - t2
        if not det_r.ok:
            return _reject(loc, "right", f"right image: {det_r.reason}")
        loc.right_point = det_r.reference
        u_r, v_r = det_r.reference_ideal
        loc.right_rectified = np.array([u_r, v_r])
        loc.disparity_edges = float(u_l - u_r)
        loc.epipolar_error = float(v_l - v_r)
        if abs(loc.epipolar_error) > opt.epipolar_tolerance:
            return _reject(loc, "check", f"the left and right reference points are {abs(loc.epipolar_error):.2f} px "
                           f"apart across the epipolar line (limit {opt.epipolar_tolerance} px): a wrong match, or "
                           "the stereo calibration no longer fits the cameras")
        corner_rows = np.abs(det_l.outline.corners_ideal[:, 1] - det_r.outline.corners_ideal[:, 1])
        if corner_rows.max() > opt.epipolar_tolerance:
            return _reject(loc, "check", f"corner {int(np.argmax(corner_rows)) + 1} of the outer square is "
                           f"{corner_rows.max():.2f} px apart across the epipolar line in the two images (limit "
                           f"{opt.epipolar_tolerance} px): the outline was found differently in the two images (an "
                           "edge partly covered?)")
        loc.corner_planarity = corner_planarity(det_l.outline.corners_ideal, det_r.outline.corners_ideal)
        if opt.max_corner_planarity is not None and loc.corner_planarity > opt.max_corner_planarity:
            return _reject(loc, "check", f"the disparities of the four corners of the outer square are "
                           f"{loc.corner_planarity:.2f} px off one plane (limit {opt.max_corner_planarity} px): "
                           "an edge was fitted through something else (partly covered?)")
        if abs(loc.disparity_edges - corr.disparity) > opt.disparity_tolerance:
            return _reject(loc, "check", f"the SSD disparity ({corr.disparity:.2f} px) and the one of the two "
                           f"reference points ({loc.disparity_edges:.2f} px) disagree by more than "
                           f"{opt.disparity_tolerance} px: a wrong match")
        monitor.step(0.9, "triangulation")
        sl, sr = det_l.sigma_px, det_r.sigma_px
        floor2 = opt.sigma_floor_px ** 2
        sigma_edges = float(np.sqrt(0.5 * (sl ** 2 + sr ** 2) + floor2))
        sigma_ssd = float(max(np.sqrt(sl ** 2 + floor2), corr.sigma_disparity / np.sqrt(2.0)))
        try:
            tri_edges = triangulate_rectified(u_l, 0.5 * (v_l + v_r), loc.disparity_edges, self.rect.P1,
                                              self.rect.P2, self.rect.R1, sigma_edges)
            tri_ssd = triangulate_rectified(u_l, v_l, corr.disparity, self.rect.P1, self.rect.P2, self.rect.R1,
                                            sigma_ssd)
        except RoboCalError as exc:
            return _reject(loc, "triangulation", exc.message)
        tri, sigma = (tri_edges, sigma_edges) if opt.method == "edges" else (tri_ssd, sigma_ssd)
        loc.point, loc.covariance, loc.sigma_px = tri.point, tri.covariance, sigma
        loc.disparity = loc.disparity_edges if opt.method == "edges" else corr.disparity
        loc.point_ssd = tri_ssd.point
        # size of the outer square from its four corners
        cl, cr = det_l.outline.corners_ideal, det_r.outline.corners_ideal
        pts = []
        for k in range(4):
            dk = cl[k, 0] - cr[k, 0]
            if dk <= self.rect.disparity_offset:
                return _reject(loc, "check", "a corner of the outer square triangulates behind the cameras: a wrong match")
            pts.append(triangulate_rectified(cl[k, 0], 0.5 * (cl[k, 1] + cr[k, 1]), dk, self.rect.P1, self.rect.P2,
                                             self.rect.R1, 1.0).point)
        loc.size_mm = float(np.mean([np.linalg.norm(pts[(k + 1) % 4] - pts[k]) for k in range(4)]))
        if opt.max_size_error is not None:
            rel = loc.size_mm / self.trained.outer_size - 1.0
            if abs(rel) > opt.max_size_error:
                return _reject(loc, "check", f"the located marker is {loc.size_mm:.1f} mm wide, the trained one "
                               f"{self.trained.outer_size:.1f} mm: a wrong match, a wrong marker size or a stereo "
                               "calibration that no longer fits")
        if opt.general_check and predicted is None:          # a cross-check, skipped when tracking
            try:
                loc.point_general = triangulate_general(self.rect.rig, det_l.reference, det_r.reference, sigma).point
            except RoboCalError:
                loc.point_general = None
        loc.orientation = marker_orientation(det_l.outline, det_r.outline, self.rect, self.trained.outer_size,
                                             loc.point, sigma_floor_px=opt.detection.edge.sigma_floor_px)
        loc.timings["total"] = time.perf_counter() - t0
        loc.ok = True
        monitor.step(1.0, "located")
        return loc

    def _detect(self, image, side: str, H_pred) -> MarkerDetection:
        pm = self.rect.pixel_map(side)
        opt = self.options.detection
        if H_pred is None:
            return detect_marker(self.trained, image, pixel_map=pm, options=opt)
        det = detect_marker(self.trained, image, pixel_map=pm, predicted=H_pred, options=opt)
        if det.ok:
            return det
        # fall back to SIFT in a region around the prediction
        outline = map_points(H_pred, self.trained.outline)
        roi = bounding_box(expand_quad(outline, 1.6), 24.0, self.rect.image_size)
        det2 = detect_marker(self.trained, image, pixel_map=pm, search_roi=roi, options=opt)
        return det2 if det2.ok else detect_marker(self.trained, image, pixel_map=pm, options=opt)

    def _detect_right(self, right, det_l: MarkerDetection, corr: Correspondence, H_pred) -> MarkerDetection:
        pm = self.rect.right_map
        opt = self.options.detection
        if H_pred is not None:
            det = detect_marker(self.trained, right, pixel_map=pm, predicted=H_pred, options=opt)
            if det.ok:
                return det
        # where the SSD disparity puts the marker in the right image
        shifted = det_l.outline.corners_ideal - [corr.disparity, 0.0]
        outline = pm.to_raw(shifted)
        roi = bounding_box(expand_quad(outline, 1.5), 16.0, self.rect.image_size)
        det = detect_marker(self.trained, right, pixel_map=pm, search_roi=roi, options=opt)
        if det.ok or det.stage == "reference":
            return det
        # SIFT found too little in the region: take the shifted left outline as the prediction
        src = self.trained.outline.astype(np.float32)
        H = cv2.getPerspectiveTransform(src, outline.astype(np.float32))
        det2 = detect_marker(self.trained, right, pixel_map=pm, predicted=H, options=opt)
        return det2 if det2.ok else det

    def window_sweep(self, left: np.ndarray, right: np.ndarray, location: MarkerLocation,
                     sizes=tuple(range(5, 38, 2))) -> WindowSweep:
        """Minimum criteria per window size at the located left reference point (Fig. 17)."""
        if location.left_rectified is None:
            raise RoboCalError("no left reference point to correlate", hint="Locate the marker first.")
        left, right = self._check_images(left, right)
        return window_sweep(self.rect, left, right, location.left_rectified, sizes=sizes)


class MarkerTracker:
    """Tracking mode for live preview: search near the previous or a predicted position.

    `track(left, right, predicted_pose=None)`: with a predicted marker pose (4x4, plate frame
    -> left camera frame, e.g. the robot model's forward kinematics) or the previous location,
    the edge fit starts from the predicted outline without any SIFT; if that fails, SIFT runs
    in a region around the prediction; if that fails too, a cold search over the whole image."""

    def __init__(self, locator: MarkerLocator):
        self.locator = locator
        self.last: MarkerLocation | None = None

    def reset(self) -> None:
        self.last = None

    def track(self, left: np.ndarray, right: np.ndarray, predicted_pose: np.ndarray | None = None,
              predicted_point: np.ndarray | None = None) -> MarkerLocation:
        """Locate the marker near where it is expected.

        `predicted_pose` (4x4, plate frame -> left camera frame) or `predicted_point` (3,) mm
        (the marker target from the robot model's forward kinematics); without either, the
        last location. A point alone moves the last outlines there (or, with no last
        location, assumes the marker faces the camera)."""
        loc_ = self.locator
        predicted = None
        if predicted_pose is not None:
            predicted = loc_.predicted_homographies(predicted_pose)
        elif predicted_point is not None:
            X = np.asarray(predicted_point, dtype=float).reshape(3)
            if self.last is not None and self.last.ok:
                rig = loc_.rect.rig
                moved = []
                for det, cam, P in ((self.last.left, rig.left, X), (self.last.right, rig.right, rig.to_right(X))):
                    shift = cam.project(P[None])[0] - det.reference
                    moved.append(np.array([[1, 0, shift[0]], [0, 1, shift[1]], [0, 0, 1.0]])
                                 @ _fitted_h(loc_.trained, det))
                predicted = (moved[0], moved[1])
            else:
                facing = tf.make_transform(np.diag([1.0, -1.0, -1.0]), X)
                predicted = loc_.predicted_homographies(facing)
        elif self.last is not None and self.last.ok:
            predicted = (_fitted_h(loc_.trained, self.last.left), _fitted_h(loc_.trained, self.last.right))
        loc = loc_.locate(left, right, predicted=predicted)
        if not loc.ok and predicted is not None and loc.stage in ("left", "right", "ssd", "check"):
            loc = loc_.locate(left, right)
        self.last = loc if loc.ok else None
        return loc


def corner_planarity(left: np.ndarray, right: np.ndarray) -> float:
    """Largest distance (px) of a corner's disparity from the plane d = a·u + b·v + c through
    all four (rectified corners (4, 2) in both images). The square is flat and disparity is
    affine in (u, v) over a plane, so only errors of the fitted outline leave a residual."""
    A = np.column_stack([left[:, 0], 0.5 * (left[:, 1] + right[:, 1]), np.ones(4)])
    d = left[:, 0] - right[:, 0]
    coef = np.linalg.lstsq(A, d, rcond=None)[0]
    return float(np.max(np.abs(A @ coef - d)))


def square_pose(corners: np.ndarray, K: np.ndarray, size: float = 2.0) -> tuple[np.ndarray, np.ndarray]:
    """(unit plane normal, centre (mm)) of a square of side `size` seen with these 4 image
    corners (clockwise from top-left), in the frame of the camera K, from the homography
    square -> image, H ~ K [r1 r2 t]. The normal does not depend on `size`."""
    s = size / 2.0
    square = np.array([[-s, s], [s, s], [s, -s], [-s, -s]], np.float32)
    H = cv2.getPerspectiveTransform(square, np.asarray(corners, np.float32))
    M = np.linalg.inv(np.asarray(K, float)[:3, :3]) @ H
    lam = 2.0 / (np.linalg.norm(M[:, 0]) + np.linalg.norm(M[:, 1]))
    r1 = M[:, 0] / np.linalg.norm(M[:, 0])
    r2 = M[:, 1] / np.linalg.norm(M[:, 1])
    n = np.cross(r1, r2)
    t = lam * M[:, 2]
    if t[2] < 0:
        t = -t
    return n / np.linalg.norm(n), t



def _fitted_h(trained: TrainedMarker, det: MarkerDetection) -> np.ndarray:
    """Homography training px -> raw px through the fitted corners (better than SIFT's)."""
    src = trained.outline.astype(np.float32)
    return cv2.getPerspectiveTransform(src, det.outline.corners.astype(np.float32))
