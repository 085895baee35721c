"""Marker comparison (the chapter's Fig. 11 experiment): which pattern is found best?

Candidate patterns, all with the same 40 mm outer black square on a 64 mm white plate (so the
Canny stage is the same for all), differ in what is inside:

- `default`  the shipped asymmetric marker (resources/markers/default.png);
- `plain`    a plain black square: no inner texture at all;
- `checker`  a 4 × 4 checkerboard inside the band: lots of corners, but symmetric and repetitive;
- `rings`    a circle target (concentric rings): rotationally symmetric, few distinct features;
- `text`     text-like ("ROBOCAL 2024"): letter strokes, several alike.

`compare_markers` trains each pattern from the virtual lab's training image and renders it
over the same random views (anywhere in the image, rotated ±180°, 400–900 mm, tilted up to
60°, over the room), then reports per pattern the SIFT matches (after the ratio test), the
RANSAC inliers, the detection rate (reference point found within 1 px of the truth), the
wrong detections (a point given but more than 1 px off) and the reference-point error. The
asymmetric default wins: symmetric or repetitive patterns give SIFT ambiguous descriptors
(the ratio test drops them) and few consistent matches; a plain square gives none at all.
"""
from __future__ import annotations

from collections import Counter
from dataclasses import dataclass, field

import cv2
import numpy as np

from core import transforms as tf
from core.errors import RoboCalError
from core.marker.description import MarkerDescription
from core.marker.detection import DetectionOptions, detect_marker
from core.camera import PixelMap
from core.marker.training import train_marker
from core.task import Monitor

SIZE = 800
LO, HI = 150, 650          # the outer square covers pixels [150, 650)
BAND = 60                  # px, solid band inside the outer square (4.8 mm)
CORRECT_PX = 1.0           # a detection within this of the truth counts as correct


@dataclass
class CandidatePattern:
    key: str
    name: str
    note: str
    description: MarkerDescription


def _description(key: str, name: str, image: np.ndarray) -> MarkerDescription:
    a, b = LO - 0.5, HI - 0.5
    c = (SIZE - 1) / 2.0
    return MarkerDescription(name=name, image=f"{key}.png", image_width=SIZE, image_height=SIZE, outer_size=40.0,
                             plate_size=(64.0, 64.0), outer_corners_px=np.array([[a, a], [b, a], [b, b], [a, b]]),
                             reference_px=np.array([c, c]), _image=image)


def _blank() -> np.ndarray:
    img = np.full((SIZE, SIZE), 255, np.uint8)
    img[LO:HI, LO:HI] = 0
    return img


def _restore_band(img: np.ndarray) -> np.ndarray:
    img[LO:LO + BAND, LO:HI] = 0
    img[HI - BAND:HI, LO:HI] = 0
    img[LO:HI, LO:LO + BAND] = 0
    img[LO:HI, HI - BAND:HI] = 0
    return img


def plain_pattern() -> np.ndarray:
    return _blank()


def checker_pattern(cells: int = 4) -> np.ndarray:
    img = _blank()
    lo, hi = LO + BAND, HI - BAND
    step = (hi - lo) / cells
    for i in range(cells):
        for j in range(cells):
            if (i + j) % 2 == 0:
                y0, x0 = int(round(lo + i * step)), int(round(lo + j * step))
                img[y0:int(round(lo + (i + 1) * step)), x0:int(round(lo + (j + 1) * step))] = 255
    return _restore_band(img)


def rings_pattern() -> np.ndarray:
    img = _blank()
    c = (SIZE - 1) / 2.0
    shift = 4
    centre = (int(round(c * (1 << shift))), int(round(c * (1 << shift))))
    for k, r in enumerate((180, 140, 100, 60, 25)):
        colour = 255 if k % 2 == 0 else 0
        cv2.circle(img, centre, int(r * (1 << shift)), colour, -1, cv2.LINE_AA, shift)
    return _restore_band(img)


def text_pattern() -> np.ndarray:
    img = _blank()
    for text, y in (("ROBO", 330), ("CAL", 440), ("2024", 550)):
        (tw, _), _ = cv2.getTextSize(text, cv2.FONT_HERSHEY_DUPLEX, 3.0, 8)
        cv2.putText(img, text, (int((SIZE - tw) / 2), y), cv2.FONT_HERSHEY_DUPLEX, 3.0, 255, 8, cv2.LINE_AA)
    return _restore_band(img)


def candidate_patterns() -> list[CandidatePattern]:
    """The patterns compared, the shipped default first."""
    return [
        CandidatePattern("default", "Asymmetric pattern (default)", "shapes without symmetry, ~200 SIFT features",
                         MarkerDescription.default()),
        CandidatePattern("plain", "Plain black square", "no inner texture",
                         _description("plain", "Plain black square", plain_pattern())),
        CandidatePattern("checker", "Checkerboard (symmetric)", "4 x 4 squares: repetitive, 180° symmetric",
                         _description("checker", "Checkerboard", checker_pattern())),
        CandidatePattern("rings", "Circle target", "concentric rings: rotationally symmetric",
                         _description("rings", "Circle target", rings_pattern())),
        CandidatePattern("text", "Text-like", "letters and digits: strokes repeat",
                         _description("text", "Text-like", text_pattern())),
    ]


# -- random views ---------------------------------------------------------------------------------

def random_marker_pose(lab, rng: np.random.Generator, *, depth=(400.0, 900.0), max_tilt: float = 60.0,
                       both: bool = True, margin: float = 8.0, max_tries: int = 1000) -> np.ndarray:
    """A random marker plate pose (4x4, plate frame -> left camera frame) seen by the left
    (and, with `both`, the right) camera with the whole plate inside the image: centre anywhere
    in the view, depth uniform in `depth` mm, rotated uniformly ±180° about its normal, tilted
    up to `max_tilt` degrees away from facing the camera (uniform over the cap of directions)."""
    cam = lab.rig.left
    for _ in range(max_tries):
        uv = np.array([rng.uniform(0, cam.width), rng.uniform(0, cam.height)])
        z = rng.uniform(*depth)
        xy = cam.pixels_to_normalized(uv[None])[0]
        P = np.array([xy[0], xy[1], 1.0]) * z
        facing = -P / np.linalg.norm(P)
        x = np.cross([0.0, 1.0, 0.0], facing)
        x /= np.linalg.norm(x)
        R0 = np.column_stack([x, np.cross(facing, x), facing])
        phi = rng.uniform(0.0, 2 * np.pi)
        cos_t = rng.uniform(np.cos(np.deg2rad(max_tilt)), 1.0)
        R = R0 @ tf.rot_axis(np.array([np.cos(phi), np.sin(phi), 0.0]), np.arccos(cos_t)) \
            @ tf.rot_z(rng.uniform(-np.pi, np.pi))
        T = tf.make_transform(R, P)
        corners = tf.transform_points(T, lab.marker.plate_corners())
        if not cam.in_image(cam.project(corners), margin).all():
            continue
        if both and not lab.rig.right.in_image(lab.rig.right.project(lab.rig.to_right(corners)), margin).all():
            continue
        return T
    raise RoboCalError("no random marker pose keeps the marker in view of the cameras",
                       hint="Check the virtual lab's cameras and the marker size.")


def view_tilt(T: np.ndarray) -> float:
    """Degrees between the plate normal and the direction to the camera."""
    P = T[:3, 3]
    return float(np.degrees(np.arccos(np.clip(-T[:3, 2] @ P / np.linalg.norm(P), -1.0, 1.0))))


# -- comparison -----------------------------------------------------------------------------------

@dataclass
class PatternResult:
    key: str
    name: str
    note: str
    trained: bool
    training_reason: str = ""
    training_features: int = 0            # SIFT features of the training image itself
    views: int = 0
    matches: np.ndarray = field(default_factory=lambda: np.zeros(0))    # (V,) after the ratio test
    inliers: np.ndarray = field(default_factory=lambda: np.zeros(0))    # (V,) RANSAC inliers
    errors: np.ndarray = field(default_factory=lambda: np.zeros(0))     # (V,) px, inf when not found
    reasons: dict = field(default_factory=dict)                          # rejection reason -> count

    @property
    def detection_rate(self) -> float:
        """Views where the reference point was found within CORRECT_PX of the truth."""
        return float(np.mean(self.errors <= CORRECT_PX)) if self.views else 0.0

    @property
    def wrong(self) -> int:
        """Views where a point was given but more than CORRECT_PX off (a silent wrong point)."""
        return int(np.sum(np.isfinite(self.errors) & (self.errors > CORRECT_PX)))

    @property
    def mean_matches(self) -> float:
        return float(self.matches.mean()) if self.views else 0.0

    @property
    def mean_inliers(self) -> float:
        return float(self.inliers.mean()) if self.views else 0.0

    @property
    def median_error(self) -> float:
        ok = self.errors[np.isfinite(self.errors)]
        return float(np.median(ok)) if ok.size else float("nan")

    def summary(self) -> dict:
        return {"key": self.key, "name": self.name, "trained": self.trained,
                "training_reason": self.training_reason or None, "training_features": self.training_features,
                "views": self.views, "mean_matches": self.mean_matches, "mean_inliers": self.mean_inliers,
                "detection_rate": self.detection_rate, "wrong": self.wrong, "median_error_px": self.median_error,
                "reasons": dict(self.reasons)}


@dataclass
class ComparisonResult:
    patterns: list[PatternResult]
    views: int
    recommended: str            # key of the pattern with the best detection rate (then inliers)

    def table(self) -> str:
        lines = [f"{'pattern':<30} {'features':>8} {'matches':>8} {'inliers':>8} {'detected':>9} {'wrong':>6} "
                 f"{'median err':>10}"]
        for p in self.patterns:
            err = f"{p.median_error:.3f} px" if np.isfinite(p.median_error) else "-"
            lines.append(f"{p.name:<30} {p.training_features:>8d} {p.mean_matches:>8.1f} {p.mean_inliers:>8.1f} "
                         f"{100 * p.detection_rate:>8.0f}% {p.wrong:>6d} {err:>10}")
        return "\n".join(lines)


def _lab_with_marker(lab, marker: MarkerDescription):
    from core.virtual_lab.lab import VirtualLab
    return VirtualLab(lab.rig, lab.nominal_robot, lab.true_robot, lab.board, marker, lab.room, errors=lab.errors,
                      base_error=lab.base_error, noise=lab.noise, seed=lab.seed)


def compare_markers(patterns: list[CandidatePattern] | None = None, *, views: int = 40, seed: int = 0, lab=None,
                    options: DetectionOptions | None = None, progress=None, cancelled=None) -> ComparisonResult:
    """Train every pattern and detect it in the same `views` random views (left camera)."""
    from core.virtual_lab.lab import VirtualLab

    monitor = Monitor(progress, cancelled)
    patterns = patterns or candidate_patterns()
    lab = lab or VirtualLab.create(seed=seed)
    pm = PixelMap(lab.rig.left)
    pose_rng = np.random.default_rng([seed, 11])
    poses = [random_marker_pose(lab, pose_rng, both=False) for _ in range(views)]
    truth = lab.rig.left.project(np.array([T[:3, 3] for T in poses]))
    results = []
    total = len(patterns) * (views + 1)
    done = 0
    for pat in patterns:
        plab = _lab_with_marker(lab, pat.description)
        res = PatternResult(pat.key, pat.name, pat.note, False, views=views)
        monitor.step(done / total, f"training {pat.name}")
        geometry = plab.training_geometry()
        try:
            trained = train_marker(plab.render_training_image(), geometry["outer_corners_px"],
                                   outer_size=pat.description.outer_size, name=pat.name)
            res.trained = True
            res.training_features = trained.n_image_features
        except RoboCalError as exc:
            res.training_reason = exc.message
            import re
            m = re.search(r"only (\d+) SIFT features", exc.message)
            res.training_features = int(m.group(1)) if m else 0
        done += 1
        matches, inliers, errors = np.zeros(views), np.zeros(views), np.full(views, np.inf)
        reasons: Counter = Counter()
        for i, T in enumerate(poses):
            monitor.step(done / total, f"{pat.name}: view {i + 1}/{views}")
            done += 1
            if not res.trained:
                reasons["not trained"] += 1
                continue
            img, _ = plab.render_marker_at(T, np.random.default_rng([seed, 12, i]))
            det = detect_marker(trained, img, pixel_map=pm, options=options)
            if det.area is not None:
                matches[i] = det.area.n_matches
                inliers[i] = det.area.n_inliers
            if det.ok:
                errors[i] = float(np.linalg.norm(det.reference - truth[i]))
            else:
                reasons[_short(det.reason)] += 1
        res.matches, res.inliers, res.errors, res.reasons = matches, inliers, errors, dict(reasons)
        results.append(res)
    best = max(results, key=lambda r: (r.detection_rate, -r.wrong, r.mean_inliers))
    monitor.step(1.0, "done")
    return ComparisonResult(results, views, best.key)


def _short(reason: str) -> str:
    """A reason without its numbers, to count alike reasons together."""
    head = reason.split(":")[0] if reason.startswith("no marker found") else reason
    return head.split(" (")[0][:80]
