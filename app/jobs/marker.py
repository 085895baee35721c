"""The Marker step's work, plain Python run on worker threads by app/pages/marker: the training
image (virtual lab camera or a file), training, one live stereo pair, the verification over
random robot poses, the comparison of candidate markers; and the step's files in the project
(marker.npz, marker_training.png, marker_verification.json, and marker_details.json with the
crops of the last located live pair: what the report draws).

Points are in mm in the left camera frame; image coordinates in px. The virtual lab is an
argument (the page asks `state.labs.when_ready` for it first).
"""
from __future__ import annotations

import contextlib
import math
import re
import time
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path

import cv2
import numpy as np

from app.lab import ComparisonResult, VirtualLab, candidate_patterns, compare_markers
from app.pages.measurement_inputs import TRAINING_FILE, VERIFICATION_FORMAT, marker_file, verification_file
from core.errors import RoboCalError
from core.files import atomic_write_json, atomic_write_many, read_json
from core.locks import output_lock, output_locks
from core.images import encode_png, load_gray
from core.marker.correspondence import WindowSweep
from core.marker.details_file import DETAILS_FILE, LIVE_IMAGES, MarkerDetails
from core.marker.location import MarkerLocation, MarkerLocator
from core.marker.training import TrainedMarker, find_outline, train_marker
from core.project import Output
from core.provenance import changed_inputs, record_inputs
from core.stereo.file import StereoFile
from core.stereo.point_uncertainty import calibration_covariance, parameter_covariance
from core.task import Cancelled, Monitor

CROP_MARGIN = 0.18           # default crop: the found outline enlarged by this fraction per side


# -- training ----------------------------------------------------------------------------------
@dataclass
class TrainingImage:
    image: np.ndarray                 # (H, W) uint8
    source: str
    outline: np.ndarray | None        # automatically found outer square (px), or None
    outline_problem: str = ""
    outer_size: float | None = None   # mm, when the source knows it (the virtual lab's marker)


def auto_outline(image: np.ndarray) -> tuple[np.ndarray | None, str]:
    """The marker's outer square (4x2 px) found in `image`, or None and why not."""
    try:
        return find_outline(image), ""
    except RoboCalError as exc:
        return None, exc.message


def capture_training_image(lab: VirtualLab, *, progress=None, cancelled=None) -> TrainingImage:
    """The virtual lab's training image (frontal view of the marker plate)."""
    monitor = Monitor(progress, cancelled)
    monitor.step(0.8, "taking the training image")
    image = lab.render_training_image()
    outline, problem = auto_outline(image)
    return TrainingImage(image, "virtual lab camera", outline, problem, float(lab.marker.outer_size))


def load_training_image(path: str | Path) -> TrainingImage:
    """A training image from a file (grey levels), with its outline found if possible."""
    path = Path(path)
    image, why = load_gray(path)
    if image is None:
        raise RoboCalError(f"cannot read the image: {why}", source=path, hint="Choose a png or jpg image.")
    outline, problem = auto_outline(image)
    return TrainingImage(image, str(path), outline, problem)


def crop_around(outline: np.ndarray, w: int, h: int) -> tuple[int, int, int, int]:
    """The crop box (x0, y0, x1, y1) px around `outline`, CROP_MARGIN larger per side, inside w x h."""
    q = np.asarray(outline, dtype=float)
    x0, y0 = q.min(axis=0)
    x1, y1 = q.max(axis=0)
    mx, my = CROP_MARGIN * (x1 - x0), CROP_MARGIN * (y1 - y0)
    return (int(max(0, np.floor(x0 - mx))), int(max(0, np.floor(y0 - my))),
            int(min(w, np.ceil(x1 + mx))), int(min(h, np.ceil(y1 + my))))


@dataclass
class Training:
    trained: TrainedMarker
    offset: np.ndarray                # (2,) px: crop origin in the shown image
    box: tuple[int, int, int, int] | None


def train_job(image: np.ndarray, box, outer_size: float, source: str, *, progress=None, cancelled=None) -> Training:
    """Train on the image, or on its crop `box` (x0, y0, x1, y1) px; `outer_size` in mm."""
    if box is not None:
        x0, y0, x1, y1 = box
        crop = np.ascontiguousarray(image[y0:y1, x0:x1])
        offset = np.array([x0, y0], dtype=float)
    else:
        crop, offset = image, np.zeros(2)
    trained = train_marker(crop, outer_size=outer_size, name="marker", source=source,
                           progress=progress, cancelled=cancelled)
    return Training(trained, offset, box)


def camera_training_image(cameras, *, progress=None, cancelled=None) -> TrainingImage:
    """The training image from the left camera of the chosen cameras (app.hardware.LiveCameras):
    the marker plate held facing it."""
    monitor = Monitor(progress, cancelled)
    monitor.step(0.3, "taking the training image")
    image = _grey(cameras.capture().left)
    outline, problem = auto_outline(image)
    return TrainingImage(image, "left camera", outline, problem, None)


def _grey(image: np.ndarray) -> np.ndarray:
    return cv2.cvtColor(image, cv2.COLOR_BGR2GRAY) if image.ndim == 3 else image


# -- live pair ---------------------------------------------------------------------------------
@dataclass
class LiveResult:
    index: int
    q: np.ndarray
    left: np.ndarray
    right: np.ndarray
    location: MarkerLocation
    sweep: WindowSweep | None
    truth: np.ndarray | None          # (3,) mm, the lab's true marker position
    seconds: float

    @property
    def error(self) -> float:
        """Distance (mm) of the located point from the truth; NaN when either is missing."""
        if self.truth is None or not self.location.ok:
            return float("nan")
        return float(np.linalg.norm(self.location.point - self.truth))


def _move(driver, q) -> None:
    if driver is not None and driver.connected:
        driver.move_to(q)          # refuses (RoboCalError) when stopped: nothing is moved


def live_pair(lab: VirtualLab, locator: MarkerLocator, index: int, seed: int, driver=None, *, progress=None,
              cancelled=None) -> LiveResult:
    """The robot at a random visible pose: render the pair, locate the marker, sweep the window."""
    monitor = Monitor(progress, cancelled)
    t0 = time.perf_counter()
    monitor.step(0.0, "choosing a visible pose")
    q = lab.random_visible_poses(1, np.random.default_rng([seed, 31, index]))[0]
    _move(driver, q)
    monitor.step(0.1, "capturing the pair")
    left, right = lab.render_marker_pair(q, np.random.default_rng([seed, 32, index]))
    monitor.step(0.3, "locating the marker")
    location = locator.locate(left, right)
    sweep = None
    if location.left_rectified is not None:
        monitor.step(0.85, "window-size sweep")
        sweep = locator.window_sweep(left, right, location)
    monitor.step(1.0, "done")
    return LiveResult(index, q, left, right, location, sweep, lab.marker_position(q), time.perf_counter() - t0)


def camera_live_pair(cameras, locator: MarkerLocator, index: int, driver=None, *, progress=None,
                     cancelled=None) -> LiveResult:
    """A pair from the chosen cameras with the robot where it is (its joints read when a robot
    is connected, else NaN): locate the marker, sweep the window. No truth to compare with."""
    monitor = Monitor(progress, cancelled)
    t0 = time.perf_counter()
    q = driver.current_joints() if driver is not None and driver.connected else np.full(0, np.nan)
    monitor.step(0.1, "capturing the pair")
    frames = cameras.capture()
    left, right = _grey(frames.left), _grey(frames.right)
    monitor.step(0.3, "locating the marker")
    location = locator.locate(left, right)
    sweep = None
    if location.left_rectified is not None:
        monitor.step(0.85, "window-size sweep")
        sweep = locator.window_sweep(left, right, location)
    monitor.step(1.0, "done")
    return LiveResult(index, q, left, right, location, sweep, None, time.perf_counter() - t0)


# -- verification ------------------------------------------------------------------------------
@dataclass
class VerificationResult:
    n: int
    stereo: str
    depth: np.ndarray                 # (n,) true depth (mm), NaN when unknown
    errors: np.ndarray                # (n,) mm against the truth, NaN when not located
    sigmas: np.ndarray                # (n,) mm, √(σx²+σy²+σz²), NaN when not located
    located: np.ndarray               # (n,) bool
    reasons: Counter = field(default_factory=Counter)
    seconds: float = 0.0
    cancelled_after: int | None = None    # Cancel came after this many poses (the result holds them)
    planned: int = 0                      # poses asked for (0: n); more than n while running or cancelled
    # (n,) mm, √trace of the point's covariance due to the stereo calibration's parameter
    # uncertainty (core/stereo/point_uncertainty.py); NaN when not located or that is unknown
    calibration_sigmas: np.ndarray | None = None

    @property
    def poses_planned(self) -> int:
        return self.planned or self.n

    def first(self, k: int) -> "VerificationResult":
        """A copy of the first k poses (what was measured when the run was looked at or cancelled)."""
        return VerificationResult(k, self.stereo, self.depth[:k].copy(), self.errors[:k].copy(),
                                  self.sigmas[:k].copy(), self.located[:k].copy(), Counter(self.reasons),
                                  self.seconds, self.cancelled_after, self.poses_planned,
                                  None if self.calibration_sigmas is None else self.calibration_sigmas[:k].copy())

    @property
    def n_located(self) -> int:
        return int(np.count_nonzero(self.located))

    @property
    def detection_rate(self) -> float:
        return self.n_located / self.n if self.n else 0.0

    def _ok(self) -> np.ndarray:
        e = self.errors[self.located]
        return e[np.isfinite(e)]

    @property
    def median_error(self) -> float:
        e = self._ok()
        return float(np.median(e)) if e.size else float("nan")

    @property
    def rms_error(self) -> float:
        e = self._ok()
        return float(np.sqrt(np.mean(e ** 2))) if e.size else float("nan")

    @property
    def max_error(self) -> float:
        e = self._ok()
        return float(e.max()) if e.size else float("nan")

    @property
    def median_sigma(self) -> float:
        """Median σ (mm) of the image noise propagated through triangulation."""
        return self._located_median(self.sigmas)

    def _located_median(self, values: np.ndarray | None) -> float:
        s = values[self.located] if values is not None else np.empty(0)
        s = s[np.isfinite(s)]
        return float(np.median(s)) if s.size else float("nan")

    @property
    def median_calibration_sigma(self) -> float:
        """Median σ (mm) the stereo calibration's uncertainty alone gives a point; NaN if unknown."""
        return self._located_median(self.calibration_sigmas)

    @property
    def median_total_sigma(self) -> float:
        """Median of √(σ_image² + σ_calibration²) (mm): the predicted σ with the calibration's share."""
        if self.calibration_sigmas is None:
            return float("nan")
        return self._located_median(np.hypot(self.sigmas, self.calibration_sigmas))

    def to_dict(self) -> dict:
        def num(v):
            return None if not math.isfinite(v) else round(float(v), 6)

        return {"poses": self.n, "located": self.n_located, "detection_rate": round(self.detection_rate, 4),
                "median_error_mm": num(self.median_error), "rms_error_mm": num(self.rms_error),
                "max_error_mm": num(self.max_error), "median_sigma_mm": num(self.median_sigma),
                "median_calibration_sigma_mm": num(self.median_calibration_sigma),
                "median_total_sigma_mm": num(self.median_total_sigma),
                "reasons": dict(self.reasons), "stereo": self.stereo}


def run_verification(lab: VirtualLab, locator: MarkerLocator, n: int, seed: int, run: int, stereo: str,
                     driver=None, calibration_cov: np.ndarray | None = None, *, shown=None, progress=None,
                     cancelled=None) -> VerificationResult:
    """Locate the marker at n random visible robot poses of the virtual lab; compare with the truth.
    `calibration_cov`: the stereo parameters' covariance (stereo_parameter_covariance), propagated
    to each located point as its calibration σ. `shown(result so far)` after every pose (a copy;
    from the worker thread). Cancel ends the run after the poses measured: they come back, with
    `cancelled_after`."""
    monitor = Monitor(progress, cancelled)
    t0 = time.perf_counter()
    monitor.step(0.0, "choosing visible poses")
    Q = lab.random_visible_poses(n, np.random.default_rng([seed, 33, run]))
    res = VerificationResult(n, stereo, np.full(n, np.nan), np.full(n, np.nan), np.full(n, np.nan),
                             np.zeros(n, bool))
    calibration = locator.rect.calibration
    if calibration_cov is not None and calibration is not None:
        res.calibration_sigmas = np.full(n, np.nan)
    for i, q in enumerate(Q):
        try:
            monitor.step(i / n, f"pose {i + 1} of {n}")
        except Cancelled:
            if i == 0:
                raise
            res.seconds, res.cancelled_after = time.perf_counter() - t0, i
            return res.first(i)
        _move(driver, q)
        left, right = lab.render_marker_pair(q, np.random.default_rng([seed, 34, run, i]))
        truth = lab.marker_position(q)
        res.depth[i] = truth[2]
        loc = locator.locate(left, right)
        if loc.ok:
            res.located[i] = True
            res.errors[i] = float(np.linalg.norm(loc.point - truth))
            res.sigmas[i] = float(np.linalg.norm(loc.sigma)) if loc.sigma is not None else np.nan
            if res.calibration_sigmas is not None:
                cov = calibration_covariance(calibration.K1, calibration.K2, calibration.R, calibration.T,
                                             loc.point, calibration_cov)
                res.calibration_sigmas[i] = math.sqrt(max(float(np.trace(cov)), 0.0))
        else:
            res.reasons[short_reason(loc.reason)] += 1
        if shown is not None:
            res.seconds = time.perf_counter() - t0
            shown(res.first(i + 1))
    res.seconds = time.perf_counter() - t0
    with contextlib.suppress(Cancelled):        # a Cancel after the last pose: every pose is measured
        monitor.step(1.0, "done")
    return res


def stereo_parameter_covariance(calibration: StereoFile | None, details: Path | None, result=None
                                ) -> np.ndarray | None:
    """The covariance of `calibration`'s parameters (core.stereo.file.TRIANGULATION_PARAMETERS):
    from its details file (stereo.json) or the Stereo step's `result` in memory when that result is
    this calibration; None when unknown (imported from another tool, the virtual lab's true rig)."""
    if calibration is None:
        return None
    if details is not None:
        cov = parameter_covariance(details, calibration.K1, calibration.K2, calibration.T)
        if cov is not None:
            return cov
    cov = getattr(result, "covariance", None)
    if cov is not None and all(np.allclose(getattr(result.file, k), getattr(calibration, k), rtol=1e-9, atol=1e-9)
                               for k in ("K1", "K2", "R", "T")):
        return cov
    return None


def short_reason(reason: str) -> str:
    """A rejection reason without its numbers, so that alike reasons are counted together."""
    text = re.sub(r"\(.*?\)", "", reason or "no reason given")
    text = re.sub(r"-?\d+(\.\d+)?", "#", text)
    return " ".join(text.split())[:110]


# -- comparison --------------------------------------------------------------------------------
@dataclass
class Comparison:
    result: ComparisonResult
    images: dict                      # pattern key -> small (64 x 64) picture of the pattern


def run_comparison(lab: VirtualLab, views: int, seed: int, *, progress=None, cancelled=None) -> Comparison:
    """Every candidate pattern trained and detected in the same `views` random views of the lab."""
    patterns = candidate_patterns()
    images = {}
    for p in patterns:
        try:
            images[p.key] = cv2.resize(p.description.load_image(), (64, 64), interpolation=cv2.INTER_AREA)
        except (RoboCalError, cv2.error, OSError):
            pass
    result = compare_markers(patterns, views=views, seed=seed, lab=lab, progress=progress, cancelled=cancelled)
    return Comparison(result, images)


# -- the step's files in the project -----------------------------------------------------------
def save_trained(project, trained: TrainedMarker) -> Path:
    """marker.npz and marker_training.png into the project (atomic); the old verification
    record belongs to the old marker and is removed. Returns the path of marker.npz."""
    path = marker_file(project)
    files = {path: trained.to_bytes()}
    try:
        files[Path(project.folder) / TRAINING_FILE] = encode_png(trained.image, "the training image")
    except RoboCalError:
        pass                                    # marker.npz holds the image too: the PNG is only a copy to look at
    with output_locks(files):                   # not while a robocal command writes them
        atomic_write_many(files)                # both, or neither changed
    record_marker_inputs(project)
    old = [verification_file(project), details_file(project)] + [Path(project.folder) / n for n in LIVE_IMAGES.values()]
    for record in old:
        try:
            record.unlink(missing_ok=True)
        except OSError as exc:
            raise RoboCalError(f"cannot remove the old marker's record ({exc.strerror})", source=record) from exc
    return path


def write_verification(project, marker_name: str, record: dict) -> None:
    """marker_verification.json: the marker `marker_name` was located (`record` says how), with
    the project's stereo.yaml of now (recorded beside marker.npz)."""
    with output_lock(verification_file(project)):
        atomic_write_json(verification_file(project), {"format": VERIFICATION_FORMAT, "marker": marker_name, **record})
    record_marker_inputs(project)


def marker_inputs(project) -> dict[str, Path]:
    """The project files the marker's training and verification are made with: stereo.yaml (when
    the project has one; a marker checked with the Stereo step's unsaved result records none)."""
    path = project.path(Output.STEREO)
    return {path.name: path} if path.is_file() else {}


def record_marker_inputs(project) -> None:
    """Record beside marker.npz the stereo.yaml it was trained and verified with (core.provenance)."""
    record_inputs(marker_file(project), marker_inputs(project))


def marker_changed_inputs(project) -> list[str]:
    """The inputs changed since the project's marker was trained or verified with them ([]: up to
    date, or nothing recorded)."""
    path = project.path(Output.STEREO)
    return changed_inputs(marker_file(project), {path.name: path})


def recorded_verification(project) -> bool:
    """The project records a verification that located its marker at least once."""
    path = verification_file(project)
    if not path.is_file():
        return False
    try:
        data = read_json(path)
    except RoboCalError:
        return False
    return data.get("format") == VERIFICATION_FORMAT and int(data.get("located", 0) or 0) > 0


# -- what the report draws (marker_details.json and the live pair's crops) --------------------
DETAIL_MAX_POINTS = 400       # edge pixels / keypoints kept per layer and image (evenly subsampled)
DETAIL_CROP_MARGIN = 0.45     # crop: the marker's box enlarged by this fraction per side
DETAIL_CROP_SIDE = 360        # px: a larger crop is downsampled to this side


def details_file(project) -> Path:
    return Path(project.folder) / DETAILS_FILE


def _pts(points, digits: int = 2) -> list:
    """(N, 2) px as a list, at most DETAIL_MAX_POINTS (evenly spaced), rounded."""
    p = np.asarray(points if points is not None else np.zeros((0, 2)), dtype=float).reshape(-1, 2)
    if len(p) > DETAIL_MAX_POINTS:
        p = p[np.linspace(0, len(p) - 1, DETAIL_MAX_POINTS).round().astype(int)]
    return np.round(p, digits).tolist()


def _vec(v, digits: int = 4):
    return None if v is None else np.round(np.asarray(v, dtype=float), digits).reshape(-1).tolist()


def _crop(image: np.ndarray, det) -> tuple[bytes, dict]:
    """A PNG of `image` around the marker found by `det` and where it sits: `origin` (x0, y0) px
    of its top-left pixel in the image, `scale` crop px per image px."""
    h, w = image.shape[:2]
    shapes = [s for s in (det.outline.corners if det.outline is not None else None,
                          det.area.outline if det.area is not None else None) if s is not None]
    if shapes:
        q = np.vstack([np.asarray(s, float).reshape(-1, 2) for s in shapes])
        (x0, y0), (x1, y1) = q.min(axis=0), q.max(axis=0)
        m = DETAIL_CROP_MARGIN * max(x1 - x0, y1 - y0)
        x0, y0 = int(max(0, np.floor(x0 - m))), int(max(0, np.floor(y0 - m)))
        x1, y1 = int(min(w, np.ceil(x1 + m))), int(min(h, np.ceil(y1 + m)))
    else:
        x0, y0, x1, y1 = 0, 0, w, h
    crop = np.ascontiguousarray(image[y0:y1, x0:x1])
    scale = min(1.0, DETAIL_CROP_SIDE / max(crop.shape[:2]))
    if scale < 1.0:
        crop = cv2.resize(crop, (max(1, round(crop.shape[1] * scale)), max(1, round(crop.shape[0] * scale))),
                          interpolation=cv2.INTER_AREA)
        scale = crop.shape[1] / (x1 - x0)
    return encode_png(crop, "the live pair's crop"), {"origin": [x0, y0], "scale": round(float(scale), 6),
                                                     "image_size": [w, h]}


def _detection_details(det) -> dict:
    """Every stage of one image's detection, in image px."""
    out: dict = {"found": bool(det.ok), "reason": det.reason}
    a, o = det.area, det.outline
    if a is not None:
        inl = np.asarray(a.inliers, bool)
        scene = np.asarray(a.match_scene, float).reshape(-1, 2)
        if len(inl) != len(scene):
            inl = np.zeros(len(scene), bool)
        out["sift"] = {"mode": a.mode, "matches": int(len(scene)), "agreeing": int(inl.sum()),
                       "agreeing_points": _pts(scene[inl]), "other_points": _pts(scene[~inl]),
                       "outline": _pts(a.outline), "reference": _vec(a.sift_reference, 3),
                       "roi": [int(v) for v in a.roi]}
    if o is not None:
        edges = np.asarray(o.edge_pixels, float).reshape(-1, 2)
        side = np.asarray(o.edge_side, int)
        used = side >= 0 if len(side) == len(edges) else np.ones(len(edges), bool)
        out["canny"] = {"ok": bool(o.ok), "roi": [int(v) for v in o.roi], "edge_points": _pts(edges[used], 1),
                        "fitted": _pts(o.outline_polyline if o.outline_polyline is not None else o.corners, 3),
                        "corners": _pts(o.corners, 3), "reference": _vec(o.reference, 4),
                        "sigma_px": float(o.sigma_px)}
    return out


def live_details(live: LiveResult) -> tuple[dict, dict[str, bytes]]:
    """The record of a located live pair for the report (marker_details.json's "live") and its
    two crops as PNG (LIVE_IMAGES' keys)."""
    loc = live.location
    record: dict = {"pair": live.index, "error_mm": live.error, "point_mm": _vec(loc.point, 4),
                    "sigma_mm": _vec(loc.sigma, 5) if loc.sigma is not None else None,
                    "disparity_px": loc.disparity, "images": {}}
    pngs = {}
    for side, det, image in (("left", loc.left, live.left), ("right", loc.right, live.right)):
        if det is None:
            continue
        pngs[side], where = _crop(image, det)
        record["images"][side] = {"file": LIVE_IMAGES[side], **where, **_detection_details(det)}
    c = loc.correspondence
    if c is not None:
        plain = np.asarray(c.plain_criteria if c.plain_criteria is not None else c.criteria, float)
        hits = np.flatnonzero(plain == c.plain_second_minimum) if len(plain) else []
        record["ssd"] = {"window": [int(v) for v in c.window], "disparities": _vec(c.disparities, 3),
                         "criteria": _vec(plain, 3), "searched": _vec(c.criteria, 3) if c.warped else None,
                         "minimum": [c.plain_disparity, c.plain_minimum],
                         "second": [float(c.disparities[hits[0]]), float(c.plain_second_minimum)] if len(hits)
                         else None,
                         "disparity": c.disparity, "reliability": c.reliability}
    if live.sweep is not None:
        s = live.sweep
        record["sweep"] = {"sizes": [int(v) for v in s.sizes], "minima": _vec(s.minima, 3),
                           "disparities": _vec(s.disparities, 4), "reliabilities": _vec(s.reliabilities, 4),
                           "located": c.disparity if c is not None and c.ok else None}
    return record, pngs


def verification_details(v: VerificationResult) -> dict:
    """Per-pose numbers of a verification for the report (marker_details.json's "verification")."""
    return {"poses": v.n, "located": v.n_located, "stereo": v.stereo, "depth_mm": _vec(v.depth, 3),
            "errors_mm": _vec(v.errors, 6), "sigmas_mm": _vec(v.sigmas, 6),
            "median_error_mm": v.median_error, "rms_error_mm": v.rms_error}


def write_details(project, marker_name: str, *, live: LiveResult | None = None,
                  verification: VerificationResult | None = None) -> Path:
    """Put the located `live` pair (its record and crops) or the `verification` into
    marker_details.json, keeping the other part when it is of the same marker; one atomic write."""
    path = details_file(project)
    try:
        old = MarkerDetails.read(path) if path.is_file() else None
    except RoboCalError:
        old = None
    details = old if old is not None and old.marker == marker_name else MarkerDetails(marker_name)
    crops: dict = {}
    if live is not None:
        details.live, pngs = live_details(live)
        crops = {Path(project.folder) / LIVE_IMAGES[side]: png for side, png in pngs.items()}
    if verification is not None:
        details.verification = verification_details(verification)
    return details.write(path, also=crops)
