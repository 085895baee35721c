"""Step 3, Marker: train the end-effector marker, then check its 3D location on stereo pairs.

The chapter's chain, each stage drawn from what core returns:

1. **Training** (core.marker.training.train_marker, worker thread): a training image loaded
   from a file or taken with the virtual lab's camera; the outer black square is found
   automatically (drawn dashed) or inside a crop rectangle the user drags; SIFT keypoints,
   the fitted outline and its reference point (the intersection of the diagonals) are drawn.
   The marker goes into the project (marker.npz, marker_training.png) and to
   ``state.marker``.
2. **Live pair** (virtual lab: the robot at a random visible pose, "Next pose"): in both
   images the SIFT matches (agreeing / not), the homography's outline, the region of
   interest, the Canny edge pixels and the fitted outline, the reference point; the 3D point
   (mm, left camera frame) with its σ and, in the virtual lab, its error against the truth.
3. **SSD correlation**: the criteria curve along the epipolar line (Fig. 16) and the
   window-size sweep (Fig. 17).
4. **Verification** over N random robot poses (worker, progress, Cancel): detection rate,
   median and RMS 3D error against the truth, rejection reasons counted.
5. **Compare markers** (core.virtual_lab.marker_comparison, Fig. 11).

The stereo rectification comes from the project's stereo.yaml (else the Stereo step's
result); in the virtual lab without one, the page offers a clearly labelled preview with the
lab's true cameras. The step is complete once a marker is trained, saved and located at
least once (marker_verification.json records the last verification).
"""
from __future__ import annotations

import html
import math
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path

import cv2
import numpy as np
from PySide6.QtCore import QSize, Qt
from PySide6.QtGui import QIcon, QPixmap
from PySide6.QtWidgets import (QAbstractItemView, QCheckBox, QDoubleSpinBox, QFileDialog,
                               QHBoxLayout, QHeaderView, QLabel, QProgressBar, QPushButton,
                               QSpinBox, QSplitter, QTableWidget, QTableWidgetItem, QTabWidget, QVBoxLayout,
                               QWidget)

from app.pages.base import WizardPage
from app.lab import build_lab
from app.pages.measurement_inputs import (TRAINING_FILE, VERIFICATION_FORMAT, StereoSource,
                                          marker_file, preview_source, stereo_source, verification_file)
from app.pages.steps import Step
from core.marker.correspondence import WindowSweep
from core.errors import RoboCalError
from core.files import atomic_write_bytes, atomic_write_json, read_json
from app.lab import ComparisonResult, compare_markers
from core.marker.location import LocatorOptions, MarkerLocation, MarkerLocator
from core.marker.training import DEFAULT_OUTER_SIZE, TrainedMarker, find_outline, train_marker
from core.task import Monitor
from widgets.marker_views import CAPTION, MarkerImageView, TrainingImageView
from widgets.precision_plot import PrecisionPlot
from widgets.ssd_plots import CriteriaPlot, WindowSweepPlot
from widgets.thumbnail_strip import to_qimage

DEMO_VERIFY = 10             # verification poses of the autopilot
DEFAULT_VERIFY = 20
COMPARE_VIEWS = 20
CROP_MARGIN = 0.18           # default crop: the found outline enlarged by this fraction per side
TAB_TRAINING, TAB_LIVE, TAB_SSD, TAB_VERIFY, TAB_COMPARE = range(5)


# -- the work (plain Python, run on worker threads) ---------------------------------------------
@dataclass
class TrainingImage:
    image: np.ndarray                 # (H, W) uint8
    source: str
    outline: np.ndarray | None        # automatically found outer square (px), or None
    outline_problem: str = ""
    lab: object | None = None
    outer_size: float | None = None   # mm, when the source knows it (the virtual lab's marker)


def _auto_outline(image: np.ndarray) -> tuple[np.ndarray | None, str]:
    try:
        return find_outline(image), ""
    except RoboCalError as exc:
        return None, exc.message


def capture_training_image(lab=None, lab_args=None, *, progress=None, cancelled=None) -> TrainingImage:
    """The virtual lab's training image (frontal view of the marker plate)."""
    monitor = Monitor(progress, cancelled)
    if lab is None:
        monitor.step(0.0, "building the virtual lab")
        lab = build_lab(*lab_args)
    monitor.step(0.8, "taking the training image")
    image = lab.render_training_image()
    outline, problem = _auto_outline(image)
    return TrainingImage(image, "virtual lab camera", outline, problem, lab, float(lab.marker.outer_size))


def load_training_image(path: str | Path) -> TrainingImage:
    from core.images import load_gray

    path = Path(path)
    image, why = load_gray(path)
    if image is None:
        raise RoboCalError(f"cannot read the image: {why}", source=path, hint="Choose a png or jpg image.")
    outline, problem = _auto_outline(image)
    return TrainingImage(image, str(path), outline, problem)


@dataclass
class Training:
    trained: TrainedMarker
    offset: np.ndarray                # (2,) px: crop origin in the shown image
    box: tuple[int, int, int, int] | None


def train_job(image: np.ndarray, box, outer_size: float, source: str, *, progress=None, cancelled=None) -> Training:
    """Train on the image, or on its crop `box` (x0, y0, x1, y1)."""
    if box is not None:
        x0, y0, x1, y1 = box
        crop = np.ascontiguousarray(image[y0:y1, x0:x1])
        offset = np.array([x0, y0], dtype=float)
    else:
        crop, offset = image, np.zeros(2)
    trained = train_marker(crop, outer_size=outer_size, name="marker", source=source,
                           progress=progress, cancelled=cancelled)
    return Training(trained, offset, box)


@dataclass
class LiveResult:
    index: int
    q: np.ndarray
    left: np.ndarray
    right: np.ndarray
    location: MarkerLocation
    sweep: WindowSweep | None
    truth: np.ndarray | None
    seconds: float

    @property
    def error(self) -> float:
        if self.truth is None or not self.location.ok:
            return float("nan")
        return float(np.linalg.norm(self.location.point - self.truth))


def _move(driver, q) -> None:
    if driver is not None and driver.connected:
        driver.move_to(q)          # refuses (RoboCalError) when stopped: nothing is moved


def live_pair(lab, locator: MarkerLocator, index: int, seed: int, driver=None, *, progress=None,
              cancelled=None) -> LiveResult:
    """The robot at a random visible pose: render the pair, locate the marker, sweep the window."""
    import time

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
    cancelled_after: int | None = None

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
        s = self.sigmas[self.located]
        s = s[np.isfinite(s)]
        return float(np.median(s)) if s.size else float("nan")

    def to_dict(self) -> dict:
        def num(v):
            return None if not math.isfinite(v) else round(float(v), 6)

        return {"poses": self.n, "located": self.n_located, "detection_rate": round(self.detection_rate, 4),
                "median_error_mm": num(self.median_error), "rms_error_mm": num(self.rms_error),
                "max_error_mm": num(self.max_error), "median_sigma_mm": num(self.median_sigma),
                "reasons": dict(self.reasons), "stereo": self.stereo}


def run_verification(lab, locator: MarkerLocator, n: int, seed: int, run: int, stereo: str, driver=None, *,
                     progress=None, cancelled=None) -> VerificationResult:
    """Locate the marker at n random visible robot poses of the virtual lab; compare with the truth."""
    import time

    monitor = Monitor(progress, cancelled)
    t0 = time.perf_counter()
    monitor.step(0.0, "choosing visible poses")
    Q = lab.random_visible_poses(n, np.random.default_rng([seed, 33, run]))
    res = VerificationResult(n, stereo, np.full(n, np.nan), np.full(n, np.nan), np.full(n, np.nan),
                             np.zeros(n, bool))
    for i, q in enumerate(Q):
        monitor.step(i / n, f"pose {i + 1} of {n}")
        _move(driver, q)
        left, right = lab.render_marker_pair(q, np.random.default_rng([seed, 34, run, i]))
        truth = lab.marker_position(q)
        res.depth[i] = truth[2]
        loc = locator.locate(left, right)
        if loc.ok:
            res.located[i] = True
            res.errors[i] = float(np.linalg.norm(loc.point - truth))
            res.sigmas[i] = float(np.linalg.norm(loc.sigma)) if loc.sigma is not None else np.nan
        else:
            res.reasons[short_reason(loc.reason)] += 1
    res.seconds = time.perf_counter() - t0
    monitor.step(1.0, "done")
    return res


def short_reason(reason: str) -> str:
    """A rejection reason without its numbers, so that alike reasons are counted together."""
    import re

    text = re.sub(r"\(.*?\)", "", reason or "no reason given")
    text = re.sub(r"-?\d+(\.\d+)?", "#", text)
    return " ".join(text.split())[:110]


@dataclass
class Comparison:
    result: ComparisonResult
    images: dict                      # pattern key -> small (64 x 64) picture of the pattern


def run_comparison(views: int, seed: int, lab=None, lab_args=None, *, progress=None, cancelled=None) -> Comparison:
    from app.lab import candidate_patterns

    monitor = Monitor(progress, cancelled)
    if lab is None:
        monitor.step(0.0, "building the virtual lab")
        lab = build_lab(*lab_args)
    patterns = candidate_patterns()
    images = {}
    for p in patterns:
        try:
            images[p.key] = cv2.resize(p.description.load_image(), (64, 64), interpolation=cv2.INTER_AREA)
        except (RoboCalError, cv2.error, OSError):
            pass
    result = compare_markers(patterns, views=views, seed=seed, lab=lab, progress=progress, cancelled=cancelled)
    return Comparison(result, images)


# -- text helpers -------------------------------------------------------------------------------
def _esc(text) -> str:
    return html.escape(str(text))


def _mm(v: float, digits: int = 3) -> str:
    return "–" if v is None or not math.isfinite(v) else f"{v:.{digits}f}"


def location_html(live: LiveResult, stereo: StereoSource) -> str:
    loc = live.location
    if not loc.ok:
        return (f"<b style='color:#c5221f'>Not located</b> ({_esc(loc.stage)} stage): {_esc(loc.reason)}")
    x, y, z = loc.point
    sx, sy, sz = loc.sigma if loc.sigma is not None else (math.nan,) * 3
    text = (f"<b>3D point</b> (mm, left camera frame): x = <b>{x:.3f}</b> ± {sx:.3f}, y = <b>{y:.3f}</b> ± "
            f"{sy:.3f}, z = <b>{z:.3f}</b> ± {sz:.3f}")
    if live.truth is not None:
        text += f"<br><b>Error against the lab's true marker position: {live.error:.3f} mm</b>"
        if stereo.kind != "preview":
            text += " (σ propagates the image noise only; the stereo calibration adds its own error)"
    if stereo.kind == "preview":
        text += " <span style='color:#b06000'>(preview with the lab's true cameras)</span>"
    return text


def details_html(live: LiveResult) -> str:
    loc = live.location
    parts = []
    for name, det in (("left", loc.left), ("right", loc.right)):
        if det is None:
            continue
        a = det.area
        sift = f"{a.n_inliers} of {a.n_matches} SIFT matches agree" if a is not None and a.mode != "predicted" else \
            "no SIFT (predicted)"
        edge = f", reference σ {det.sigma_px:.3f} px" if det.ok else ""
        parts.append(f"{name}: {sift}{edge}")
    c = loc.correspondence
    if c is not None and c.ok:
        parts.append(f"SSD window {c.window[1]}×{c.window[0]} px: d = {c.disparity:.2f} px, minimum "
                     f"{c.minimum:.1f}, reliability {c.reliability:.3f} (0 unique … 1 ambiguous)")
    if math.isfinite(loc.disparity_edges):
        parts.append(f"disparity of the two reference points {loc.disparity_edges:.3f} px (used), SSD "
                     f"{loc.disparity_ssd:.3f} px; rows differ by {loc.epipolar_error:+.3f} px")
    if math.isfinite(loc.size_mm):
        parts.append(f"marker side {loc.size_mm:.2f} mm")
    total = loc.timings.get("total")
    if total is not None:
        parts.append(f"located in {1000 * total:.0f} ms")
    return " · ".join(_esc(p) for p in parts)


def verification_html(v: VerificationResult, truth: bool = True) -> str:
    rate = f"<b>{v.n_located} of {v.n}</b> located ({100 * v.detection_rate:.0f} %)"
    if v.cancelled_after is not None:
        rate += f" — cancelled after {v.cancelled_after} poses"
    rows = [f"<p>{rate} in {v.seconds:.1f} s.</p>"]
    if truth and v.n_located:
        rows.append("<table cellspacing='0' cellpadding='2'>"
                    f"<tr><td>median 3D error&nbsp;</td><td align='right'><b>{_mm(v.median_error)} mm</b></td></tr>"
                    f"<tr><td>RMS 3D error</td><td align='right'><b>{_mm(v.rms_error)} mm</b></td></tr>"
                    f"<tr><td>largest error</td><td align='right'>{_mm(v.max_error)} mm</td></tr>"
                    f"<tr><td>median predicted σ&nbsp;</td><td align='right'>{_mm(v.median_sigma)} mm</td></tr>"
                    "</table>")
    if v.reasons:
        rows.append("<p><b>Rejected</b> (a clear reason, never a guessed point):</p><ul>"
                    + "".join(f"<li>{n}× {_esc(r)}</li>" for r, n in v.reasons.most_common()) + "</ul>")
    elif v.n_located == v.n:
        rows.append("<p>No pose rejected.</p>")
    rows.append(f"<p style='color:#5f6368'>Stereo: {_esc(v.stereo)}. Errors are against the virtual lab's "
                "true marker positions; with a calibrated stereo.yaml they include the calibration's own "
                "error.</p>")
    return "".join(rows)


# -- the page -----------------------------------------------------------------------------------
class MarkerPage(WizardPage):
    step = Step.MARKER

    def __init__(self, state, tasks, **kwargs):
        super().__init__(state, tasks, **kwargs)
        self.training_image: TrainingImage | None = None
        self.trained: TrainedMarker | None = None
        self.trained_offset = np.zeros(2)
        self.saved_path: Path | None = None
        self.verified = False
        self.stereo = StereoSource(None, "", "no stereo calibration")
        self._preview = False            # the user asked for the lab's true cameras
        self._locator: MarkerLocator | None = None
        self.live: LiveResult | None = None
        self.verification: VerificationResult | None = None
        self.comparison: Comparison | None = None
        self._lab = None
        self._handle = None
        self._token = 0
        self._live_count = 0
        self._verify_count = 0
        self._build()
        state.projectChanged.connect(self._context_changed)
        state.robotChanged.connect(self._context_changed)
        state.labChanged.connect(self._lab_changed)
        state.stereoChanged.connect(lambda *_: self._refresh_stereo())
        self._context_changed()

    # -- construction ---------------------------------------------------------------------
    def _build(self) -> None:
        self.load_button = QPushButton("Load image…")
        self.load_button.setObjectName("loadButton")
        self.load_button.setToolTip("A sharp image of the marker: its black outer square on a bright plate")
        self.load_button.clicked.connect(lambda: self.load_dialog())
        self.capture_button = QPushButton("Capture (virtual lab)")
        self.capture_button.setObjectName("captureButton")
        self.capture_button.setToolTip("A frontal image of the marker plate with the virtual lab's camera")
        self.capture_button.clicked.connect(lambda: self.capture_training())
        self.crop_check = QCheckBox("Crop to rectangle")
        self.crop_check.setObjectName("cropCheck")
        self.crop_check.setToolTip("Drag the blue rectangle around the marker: only what is inside is trained "
                                   "(for an image with other dark squares or clutter)")
        self.crop_check.toggled.connect(self._crop_toggled)
        self.size_spin = QDoubleSpinBox()
        self.size_spin.setObjectName("sizeSpin")
        self.size_spin.setRange(1.0, 1000.0)
        self.size_spin.setDecimals(2)
        self.size_spin.setValue(DEFAULT_OUTER_SIZE)
        self.size_spin.setSuffix(" mm")
        self.size_spin.setToolTip("Side of the marker's outer black square, measured on the real marker")
        self.train_button = QPushButton("Train")
        self.train_button.setObjectName("trainButton")
        self.train_button.clicked.connect(lambda: self.train())
        self.stereo_label = QLabel()
        self.stereo_label.setObjectName("hint")
        self.stereo_label.setWordWrap(True)
        self.preview_button = QPushButton("Preview with the lab's true cameras")
        self.preview_button.setObjectName("previewButton")
        self.preview_button.setToolTip("No stereo calibration yet: locate with the virtual lab's true cameras, "
                                       "clearly labelled as a preview. Measurements need stereo.yaml.")
        self.preview_button.clicked.connect(lambda: self.use_preview())

        row0 = QHBoxLayout()
        row0.setSpacing(8)
        for w in (self.load_button, self.capture_button, self.crop_check):
            row0.addWidget(w)
        row0.addStretch(1)
        row0.addWidget(QLabel("Outer square:"))
        row0.addWidget(self.size_spin)
        row0.addWidget(self.train_button)
        row1 = QHBoxLayout()
        row1.setSpacing(8)
        row1.addWidget(self.stereo_label, 1)
        row1.addWidget(self.preview_button)
        top = QVBoxLayout()
        top.setContentsMargins(0, 0, 0, 0)
        top.setSpacing(3)
        top.addLayout(row0)
        top.addLayout(row1)

        # 1. training
        self.training_view = TrainingImageView()
        self.training_view.setObjectName("trainingView")
        self.training_view.cropChanged.connect(self._crop_changed)
        self.training_info = QLabel()
        self.training_info.setObjectName("trainingInfo")
        self.training_info.setWordWrap(True)
        self.training_info.setTextFormat(Qt.TextFormat.RichText)
        self.training_info.setAlignment(Qt.AlignmentFlag.AlignTop | Qt.AlignmentFlag.AlignLeft)
        self.training_info.setMinimumWidth(220)
        self.training_info.setMaximumWidth(300)
        training = QWidget()
        tl = QHBoxLayout(training)
        tl.setContentsMargins(4, 4, 4, 4)
        tl.addWidget(self.training_view, 1)
        tl.addWidget(self.training_info)

        # 2. live pair
        self.next_button = QPushButton("Next pose")
        self.next_button.setObjectName("nextPoseButton")
        self.next_button.setToolTip("Move the (virtual) robot to a random pose where both cameras see the marker, "
                                    "capture a pair and locate the marker")
        self.next_button.clicked.connect(lambda: self.next_pose())
        self.zoom_check = QCheckBox("Zoom on the marker")
        self.zoom_check.setChecked(True)
        self.zoom_check.setToolTip("Frame the marker (mouse wheel zooms, drag pans, double-click shows the "
                                   "whole image)")
        self.zoom_check.toggled.connect(self._zoom_toggled)
        self.point_label = QLabel()
        self.point_label.setObjectName("pointLabel")
        self.point_label.setWordWrap(True)
        self.point_label.setTextFormat(Qt.TextFormat.RichText)
        self.point_label.setTextInteractionFlags(Qt.TextInteractionFlag.TextSelectableByMouse)
        self.left_view = MarkerImageView(title="left camera")
        self.left_view.setObjectName("leftView")
        self.right_view = MarkerImageView(title="right camera")
        self.right_view.setObjectName("rightView")
        self.caption = QLabel(CAPTION)
        self.caption.setObjectName("hint")
        self.caption.setWordWrap(True)
        self.details_label = QLabel()
        self.details_label.setObjectName("hint")
        self.details_label.setWordWrap(True)
        live = QWidget()
        ll = QVBoxLayout(live)
        ll.setContentsMargins(4, 4, 4, 4)
        ll.setSpacing(4)
        row = QHBoxLayout()
        row.addWidget(self.next_button)
        row.addWidget(self.zoom_check)
        row.addWidget(self.point_label, 1)
        ll.addLayout(row)
        views = QHBoxLayout()
        views.setSpacing(4)
        views.addWidget(self.left_view)
        views.addWidget(self.right_view)
        ll.addLayout(views, 1)
        ll.addWidget(self.caption)
        ll.addWidget(self.details_label)

        # 3. SSD
        self.criteria_plot = CriteriaPlot()
        self.sweep_plot = WindowSweepPlot()
        self.ssd_note = QLabel()
        self.ssd_note.setObjectName("hint")
        self.ssd_note.setWordWrap(True)
        ssd = QWidget()
        sl = QVBoxLayout(ssd)
        sl.setContentsMargins(4, 4, 4, 4)
        split = QSplitter(Qt.Orientation.Vertical)
        split.addWidget(self.criteria_plot)
        split.addWidget(self.sweep_plot)
        split.setChildrenCollapsible(False)
        sl.addWidget(split, 1)
        sl.addWidget(self.ssd_note)

        # 4. verification
        self.verify_spin = QSpinBox()
        self.verify_spin.setObjectName("verifySpin")
        self.verify_spin.setRange(1, 500)
        self.verify_spin.setValue(DEFAULT_VERIFY)
        self.verify_spin.setToolTip("Random robot poses where both cameras see the marker")
        self.verify_button = QPushButton("Run verification")
        self.verify_button.setObjectName("verifyButton")
        self.verify_button.clicked.connect(lambda: self.verify())
        self.cancel_button = QPushButton("Cancel")
        self.cancel_button.setObjectName("cancelButton")
        self.cancel_button.clicked.connect(self.cancel)
        self.progress = QProgressBar()
        self.progress.setRange(0, 1000)
        self.progress.setTextVisible(True)
        self.progress.setFormat("%p%")
        self.verify_summary = QLabel()
        self.verify_summary.setObjectName("verifySummary")
        self.verify_summary.setWordWrap(True)
        self.verify_summary.setTextFormat(Qt.TextFormat.RichText)
        self.verify_summary.setAlignment(Qt.AlignmentFlag.AlignTop | Qt.AlignmentFlag.AlignLeft)
        self.verify_summary.setMinimumWidth(230)
        self.verify_summary.setMaximumWidth(320)
        self.precision_plot = PrecisionPlot()
        verify = QWidget()
        vl = QVBoxLayout(verify)
        vl.setContentsMargins(4, 4, 4, 4)
        row = QHBoxLayout()
        row.addWidget(QLabel("Poses:"))
        row.addWidget(self.verify_spin)
        row.addWidget(self.verify_button)
        row.addWidget(self.cancel_button)
        row.addWidget(self.progress, 1)
        vl.addLayout(row)
        body = QHBoxLayout()
        body.addWidget(self.verify_summary)
        body.addWidget(self.precision_plot, 1)
        vl.addLayout(body, 1)

        # 5. compare markers
        self.compare_spin = QSpinBox()
        self.compare_spin.setObjectName("compareSpin")
        self.compare_spin.setRange(5, 400)
        self.compare_spin.setValue(COMPARE_VIEWS)
        self.compare_spin.setToolTip("Random views (400–900 mm, tilted up to 60°) each candidate is detected in")
        self.compare_button = QPushButton("Compare markers")
        self.compare_button.setObjectName("compareButton")
        self.compare_button.clicked.connect(lambda: self.compare())
        self.compare_table = QTableWidget(0, 7)
        self.compare_table.setObjectName("compareTable")
        self.compare_table.setHorizontalHeaderLabels(["Pattern", "Features", "Matches", "Inliers", "Detected",
                                                      "Wrong", "Median error"])
        self.compare_table.setEditTriggers(QAbstractItemView.EditTrigger.NoEditTriggers)
        self.compare_table.verticalHeader().setVisible(False)
        self.compare_table.verticalHeader().setDefaultSectionSize(70)
        self.compare_table.setIconSize(QSize(64, 64))
        self.compare_table.horizontalHeader().setSectionResizeMode(QHeaderView.ResizeMode.ResizeToContents)
        self.compare_table.horizontalHeader().setSectionResizeMode(0, QHeaderView.ResizeMode.Stretch)
        self.compare_note = QLabel(
            "Five candidate patterns with the same outer square (the chapter's Fig. 11): each is trained from "
            "its own training image and detected in the same random views. <b>Features</b>: SIFT keypoints on "
            "the training image; <b>matches</b> and <b>inliers</b>: mean per view after the ratio test and "
            "agreeing with the homography; <b>detected</b>: reference point within 1 px of the truth; "
            "<b>wrong</b>: a point given more than 1 px off.")
        self.compare_note.setObjectName("hint")
        self.compare_note.setWordWrap(True)
        compare = QWidget()
        cl = QVBoxLayout(compare)
        cl.setContentsMargins(4, 4, 4, 4)
        row = QHBoxLayout()
        row.addWidget(QLabel("Views per pattern:"))
        row.addWidget(self.compare_spin)
        row.addWidget(self.compare_button)
        row.addStretch(1)
        cl.addLayout(row)
        cl.addWidget(self.compare_table, 1)
        cl.addWidget(self.compare_note)

        self.tabs = QTabWidget()
        self.tabs.setObjectName("markerTabs")
        self.tabs.addTab(training, "Training")
        self.tabs.addTab(live, "Live pair")
        self.tabs.addTab(ssd, "SSD correlation")
        self.tabs.addTab(verify, "Verification")
        self.tabs.addTab(compare, "Compare markers")

        layout = QVBoxLayout(self)
        layout.setContentsMargins(0, 0, 0, 0)
        layout.setSpacing(6)
        layout.addLayout(top)
        layout.addWidget(self.tabs, 1)
        layout.addWidget(self.status)

    # -- state ------------------------------------------------------------------------------
    @property
    def busy(self) -> bool:
        return self._handle is not None

    @property
    def locator(self) -> MarkerLocator | None:
        if self._locator is None and self.trained is not None and self.stereo.rect is not None:
            self._locator = MarkerLocator(self.trained, self.stereo.rect, LocatorOptions())
        return self._locator

    def _lab_changed(self, lab) -> None:
        if lab is not None:
            self._lab = lab

    def _current_lab(self):
        if self._lab is None and self.state.has_lab:
            self._lab = self.state.lab
        return self._lab

    def _lab_source(self) -> dict:
        lab = self._current_lab()
        return {"lab": lab} if lab is not None else {"lab_args": (self.state.robot, self.state.seed,
                                                                  float(self.state.noise))}

    def _build_lab_then(self, then, on_result=None) -> bool:
        """Build the virtual lab on the worker (`on_result`, by default `_took_lab`, keeps it and
        the state adopts it), then carry on with `then`."""
        return self._start(build_lab, self.state.robot, self.state.seed, float(self.state.noise),
                           on_result=on_result or self._took_lab, label="Building the virtual lab", then=then,
                           status="Building the virtual lab…")

    def _took_lab(self, lab) -> None:
        if lab is not None:
            self._lab = lab
            self.state.adopt_lab(lab)

    def _context_changed(self, *_) -> None:
        """Another project or robot: start again, from the project's saved marker if any."""
        self._token += 1
        if self._handle is not None:
            self._handle.cancel()
            self._handle = None
        self._lab = None
        self._preview = False
        self.training_image = None
        self.trained = None
        self.trained_offset = np.zeros(2)
        self.saved_path = None
        self.verified = False
        self.live = None
        self.verification = None
        self._locator = None
        self.training_view.set_image(None)
        self.training_view.set_auto_outline(None)
        self.training_view.clear_detection()
        self._show_live()
        self._show_verification()
        message, ok = "", None
        project = self.state.project
        if project is not None and marker_file(project).is_file():
            try:
                trained = TrainedMarker.load(marker_file(project))
            except RoboCalError as exc:
                message, ok = f"The project's marker.npz cannot be used ({exc.message}); train again.", False
            else:
                self._set_trained(trained, np.zeros(2), marker_file(project))
                self.state.set_marker(trained)
                self.training_image = TrainingImage(trained.image, trained.source or str(marker_file(project)),
                                                    trained.outline)
                self.size_spin.setValue(trained.outer_size)
                self._show_training_image()
                self.verified = self._recorded_verification()
                message = (f"This project already has a trained marker ({marker_file(project).name}, "
                           f"{trained.n_image_features} SIFT features)"
                           + (", verified: the step is done." if self.verified else
                              ". Locate it on a pair (Live pair or Verification) to finish the step."))
                ok = self.verified
        elif project is None:
            message = "No project yet: create or open one in the Setup step (1)."
        self._refresh_stereo()
        self._update_buttons()
        if message:
            self._set_status(message, ok)
        self.notify_complete()

    def _recorded_verification(self) -> bool:
        path = verification_file(self.state.project)
        if not path.is_file():
            return False
        try:
            data = read_json(path)
        except RoboCalError:
            return False
        return data.get("format") == VERIFICATION_FORMAT and int(data.get("located", 0) or 0) > 0

    def _refresh_stereo(self) -> None:
        if self._preview and self._current_lab() is not None and not self._has_calibration():
            src = preview_source(self._current_lab())
        else:
            self._preview = False
            src = stereo_source(self.state)
        changed = src.kind != self.stereo.kind or src.label != self.stereo.label
        self.stereo = src
        if changed:
            self._locator = None
        if src.rect is None:
            hint = (" In the virtual lab you can preview the location with the lab's true cameras."
                    if self.state.virtual else " Calibrate the cameras in step 2 first.")
            self.stereo_label.setText(f"<span style='color:#b06000'><b>Stereo:</b> {_esc(src.problem)}.</span>{hint}")
        elif src.kind == "preview":
            self.stereo_label.setText(f"<b style='color:#b06000'>{_esc(src.label)}</b>")
        else:
            self.stereo_label.setText(f"<b>Stereo:</b> {_esc(src.label)}")
        self.preview_button.setVisible(self.state.virtual and src.rect is None)
        self._update_buttons()

    def _has_calibration(self) -> bool:
        return stereo_source(self.state).rect is not None

    # -- WizardPage -------------------------------------------------------------------------
    def on_enter(self) -> None:
        self._refresh_stereo()
        self.notify_complete()

    def is_complete(self) -> bool:
        return self.trained is not None and self.saved_path is not None and self.verified

    def autopilot(self, done) -> None:
        if self.state.project is None or self.state.robot is None:
            done(False, "no project or robot model (Setup step)")
            return
        if not self.state.virtual:
            done(False, "the marker autopilot needs the virtual lab (load and train a marker image by hand)")
            return
        if self.busy:
            done(False, "the page is busy")
            return
        self._autopilot_done = done
        self._autopilot_next()

    def _autopilot_next(self) -> None:
        """One step of the demo: stereo (or preview) → training image → train → live pair → verify."""
        if self._autopilot_done is None:
            return
        if self.stereo.rect is None:
            if not self.use_preview(then=self._autopilot_next):
                self._finish_autopilot(False, self.status.text() or "no stereo calibration")
            return
        if self.trained is None or self.saved_path is None:
            if self.training_image is None or self.training_image.source != "virtual lab camera":
                if not self.capture_training(then=self._autopilot_next):
                    self._finish_autopilot(False, self.status.text() or "no training image")
                return
            if not self.train(then=self._autopilot_next):
                self._finish_autopilot(False, self.status.text() or "training could not start")
            return
        if self.live is None:
            if not self.next_pose(then=self._autopilot_next):
                self._finish_autopilot(False, self.status.text() or "no live pair")
            return
        if self.verification is None:
            self.verify_spin.setValue(DEMO_VERIFY)
            if not self.verify(then=self._autopilot_next):
                self._finish_autopilot(False, self.status.text() or "verification could not start")
            return
        v = self.verification
        if self.is_complete():
            self._finish_autopilot(True, f"{self.trained.n_image_features} SIFT features; {v.n_located}/{v.n} "
                                         f"located, median 3D error {_mm(v.median_error)} mm")
        else:
            self._finish_autopilot(False, "the marker was not located in any verification pose")

    # -- tasks --------------------------------------------------------------------------------
    def _start(self, fn, *args, on_result, label: str, then=None, status: str = "", **kwargs) -> bool:
        if self.busy:
            self._set_status("Busy: wait for the running task or cancel it.", False)
            return False
        self._token += 1
        token = self._token

        def result(value):
            if token != self._token:
                return
            self._handle = None
            self._update_buttons()
            try:
                on_result(value)
            except RoboCalError as exc:
                self._set_status(f"✗ {exc.message}", False)
                self._finish_autopilot(False, exc.message)
                return
            if then is not None:
                then()

        def error(message):
            if token != self._token:
                return
            self._handle = None
            self._update_buttons()
            self._set_status(f"✗ {message}", False)
            self.progress.setValue(0)
            self._finish_autopilot(False, message)

        def cancelled():
            if token != self._token:
                return
            self._handle = None
            self._update_buttons()
            self._set_status("Cancelled.", False)
            self._finish_autopilot(False, "cancelled")

        self._handle = self.run_task(fn, *args, on_result=result, on_error=error, on_cancelled=cancelled,
                                     on_progress=self._progress, label=label, **kwargs)
        self._update_buttons()
        if status:
            self._set_status(status, None)
        return True

    def cancel(self) -> None:
        if self._handle is not None:
            self._handle.cancel()

    def _progress(self, fraction: float, message: str) -> None:
        self.progress.setValue(int(round(1000 * min(max(fraction, 0.0), 1.0))))
        self.progress.setFormat(f"{message.replace('%', '%%')}  %p%" if message else "%p%")

    def _update_buttons(self) -> None:
        busy = self.busy
        has_project = self.state.project is not None
        virtual = self.state.virtual and self.state.robot is not None
        self.load_button.setEnabled(not busy and has_project)
        self.capture_button.setEnabled(not busy and has_project and virtual)
        self.crop_check.setEnabled(not busy and self.training_image is not None)
        self.train_button.setEnabled(not busy and has_project and self.training_image is not None)
        self.preview_button.setEnabled(not busy)
        ready = self.trained is not None and self.stereo.rect is not None and virtual
        self.next_button.setEnabled(not busy and ready)
        self.verify_button.setEnabled(not busy and ready)
        self.cancel_button.setEnabled(busy)
        self.compare_button.setEnabled(not busy and virtual)

    # -- stereo preview -----------------------------------------------------------------------
    def use_preview(self, then=None) -> bool:
        """Virtual lab without a stereo calibration: locate with the lab's true cameras."""
        if not self.state.virtual or self.state.robot is None:
            self._set_status("The preview needs a virtual-lab project with a robot.", False)
            return False
        if self._current_lab() is not None:
            self._preview = True
            self._refresh_stereo()
            if then is not None:
                then()
            return True

        def built(lab):
            self._took_lab(lab)
            self._preview = True
            self._refresh_stereo()
            self._set_status("Preview: locating with the virtual lab's true cameras (not a calibration).", None)

        return self._build_lab_then(then, on_result=built)

    # -- training -----------------------------------------------------------------------------
    def load_dialog(self) -> bool:
        start = str(self.state.project.folder) if self.state.project else ""
        path, _ = QFileDialog.getOpenFileName(self, "Marker training image", start,
                                              "Images (*.png *.jpg *.jpeg *.bmp *.tif *.tiff)")
        return self.load_image(path) if path else False

    def load_image(self, path: str | Path) -> bool:
        try:
            image = load_training_image(path)
        except RoboCalError as exc:
            self._set_status(f"✗ {exc.message}", False)
            return False
        self._set_training_image(image)
        return True

    def capture_training(self, then=None) -> bool:
        if not self.state.virtual or self.state.robot is None:
            self._set_status("Capture needs the virtual lab (live cameras arrive with the hardware issue); "
                             "load an image of the marker instead.", False)
            return False

        def got(image: TrainingImage):
            self._took_lab(image.lab)
            self._set_training_image(image)

        return self._start(capture_training_image, on_result=got, label="Training image", then=then,
                           status="Taking the training image…", **self._lab_source())

    def _set_training_image(self, image: TrainingImage) -> None:
        self.training_image = image
        if image.outer_size:
            self.size_spin.setValue(image.outer_size)
        self.crop_check.blockSignals(True)
        self.crop_check.setChecked(False)
        self.crop_check.blockSignals(False)
        self.training_view.set_crop_visible(False)
        self._show_training_image(trained=False)
        h, w = image.image.shape[:2]
        if image.outline is not None:
            box = _crop_around(image.outline, w, h)
            self.training_view.set_crop_box(box)
            self._set_status(f"Training image {w}x{h} px from {image.source}: the outer square was found "
                             "(dashed orange). Train, or crop to a rectangle first.", None)
        else:
            self.training_view.set_crop_box((w // 4, h // 4, 3 * w // 4, 3 * h // 4))
            self._set_status(f"Training image {w}x{h} px: {image.outline_problem} Drag a crop rectangle around "
                             "the marker, or load another image.", False)
        self._update_buttons()

    def _crop_toggled(self, on: bool) -> None:
        self.training_view.set_crop_visible(on)
        self._crop_changed(self.training_view.crop_box())

    def _crop_changed(self, box) -> None:
        """Find the outline again inside the crop (fast: no worker needed)."""
        img = self.training_image
        if img is None:
            return
        if self.crop_check.isChecked() and box is not None:
            x0, y0, x1, y1 = box
            outline, problem = _auto_outline(np.ascontiguousarray(img.image[y0:y1, x0:x1]))
            self.training_view.set_auto_outline(None if outline is None else outline + [x0, y0])
            if outline is None:
                self._set_status(f"Inside the crop: {problem}", False)
            else:
                self._set_status("Inside the crop the outer square was found (dashed orange): Train.", None)
        else:
            self.training_view.set_auto_outline(img.outline)

    def train(self, then=None) -> bool:
        img = self.training_image
        if img is None:
            self._set_status("Load or capture a training image first.", False)
            return False
        if self.state.project is None:
            self._set_status("Create or open a project first (Setup step).", False)
            return False
        box = self.training_view.crop_box() if self.crop_check.isChecked() else None
        return self._start(train_job, img.image, box, float(self.size_spin.value()), img.source,
                           on_result=self._trained, label="Training the marker", then=then,
                           status="Training: outline, edges, SIFT features of the marker and of simulated "
                                  "tilted views…")

    def _trained(self, training: Training) -> None:
        trained = training.trained
        path = self._save(trained)
        self._set_trained(trained, training.offset, path)
        self.verified = False
        self.live = None
        self.verification = None
        self._show_training_image()
        self._show_live()
        self._show_verification()
        self.state.set_marker(trained)
        self._set_status(f"✓ Trained: {trained.n_image_features} SIFT features on the marker "
                         f"({trained.n_features} with the simulated tilted views), saved as {path.name}. "
                         "Now check it on a live pair (Next pose) and run a verification.", True)
        self.tabs.setCurrentIndex(TAB_TRAINING)
        self.notify_complete()

    def _save(self, trained: TrainedMarker) -> Path:
        """marker.npz and marker_training.png into the project (atomic); the old verification
        record belongs to the old marker and is removed."""
        project = self.state.project
        path = trained.save(marker_file(project))
        ok, png = cv2.imencode(".png", trained.image)
        if ok:
            atomic_write_bytes(Path(project.folder) / TRAINING_FILE, png.tobytes())
        try:                               # the old verification was of another marker
            verification_file(project).unlink(missing_ok=True)
        except OSError as exc:
            raise RoboCalError(f"cannot remove the old verification record ({exc.strerror})",
                               source=verification_file(project)) from exc
        return path

    def _set_trained(self, trained: TrainedMarker, offset, path: Path | None) -> None:
        self.trained = trained
        self.trained_offset = np.asarray(offset, dtype=float)
        self.saved_path = path
        self._locator = None
        self._update_buttons()

    def _show_training_image(self, trained: bool = True) -> None:
        img = self.training_image
        view = self.training_view
        if img is None:
            view.set_image(None)
            self.training_info.setText("")
            return
        view.set_image(img.image)
        view.set_auto_outline(img.outline)
        t = self.trained if trained else None
        if t is None:
            view.clear_detection()
            self.training_info.setText(
                "<b>Training</b><br>The outer black square (dashed orange) is found automatically. If the image "
                "shows other dark shapes, tick <i>Crop to rectangle</i> and drag the blue rectangle around the "
                "marker. Give the side of the outer square in mm, then <b>Train</b>.")
            return
        off = self.trained_offset
        own = t.keypoint_view == 0
        view.set_auto_outline(None)
        view.show_detection(keypoints=None, inliers=t.keypoint_xy[own] + off, fitted=t.outline + off,
                            reference=t.reference_px + off, corners=t.outline + off)
        x, y = t.reference_px + off
        self.training_info.setText(
            f"<b>Trained marker</b><ul style='margin-left:-20px'>"
            f"<li><b>{t.n_image_features}</b> SIFT keypoints on the marker (green circles), "
            f"<b>{t.n_features}</b> with those of {len(set(t.keypoint_view.tolist())) - 1} simulated tilted views "
            f"(45° and 60°) that help at oblique angles</li>"
            f"<li>outer square {t.outer_size:.2f} mm, {t.px_per_mm:.2f} px/mm in this image; fitted to "
            f"σ ≈ {t.outline_sigma_px:.3f} px (green)</li>"
            f"<li>reference point (red): the intersection of the diagonals, ({x:.2f}, {y:.2f}) px</li>"
            f"<li>contrast: dark {t.dark_level:.0f}, bright {t.bright_level:.0f} grey levels</li></ul>"
            + (f"Saved: {_esc(self.saved_path.name)}, {TRAINING_FILE}." if self.saved_path else ""))

    # -- live pair ------------------------------------------------------------------------------
    def next_pose(self, then=None) -> bool:
        locator = self.locator
        if locator is None:
            self._set_status("Train the marker and provide a stereo calibration first.", False)
            return False
        lab = self._current_lab()
        if lab is None:
            return self._build_lab_then(lambda: self.next_pose(then))
        self._live_count += 1
        return self._start(live_pair, lab, locator, self._live_count, int(self.state.seed),
                           self.state.robot_connection, on_result=self._live_done, label="Live pair", then=then,
                           status="Moving to a random visible pose, capturing and locating…")

    def _live_done(self, live: LiveResult) -> None:
        self.live = live
        self._show_live()
        loc = live.location
        if loc.ok:
            self._mark_verified({"kind": "live pair", "poses": 1, "located": 1,
                                 "error_mm": None if not math.isfinite(live.error) else round(live.error, 6)})
            self._set_status(f"✓ Located in {1000 * loc.timings.get('total', live.seconds):.0f} ms: error against "
                             f"the truth {live.error:.3f} mm. Next pose for another, or run a verification.", True)
        else:
            self._set_status(f"Not located: {loc.reason}", False)
        self.tabs.setCurrentIndex(TAB_LIVE)

    def _show_live(self) -> None:
        live = self.live
        if live is None:
            for view in (self.left_view, self.right_view):
                view.set_image(None)
                view.clear_detection()
            self.point_label.setText("<span style='color:#5f6368'>Next pose moves the robot to a random pose where "
                                     "both cameras see the marker and locates it.</span>")
            self.details_label.setText("")
            self.criteria_plot.clear_curve()
            self.sweep_plot.clear_sweep()
            self.ssd_note.setText("The criteria curve and the window-size sweep appear after a live pair.")
            return
        loc = live.location
        for view, det, image in ((self.left_view, loc.left, live.left), (self.right_view, loc.right, live.right)):
            view.set_image(image)
            _draw_detection(view, det, "right image: not searched (the left one failed)" if det is None else "")
        self._zoom_toggled(self.zoom_check.isChecked())
        self.point_label.setText(location_html(live, self.stereo))
        self.details_label.setText(details_html(live))
        self._show_ssd()

    def _zoom_toggled(self, on: bool) -> None:
        for view in (self.left_view, self.right_view):
            if on:
                view.zoom_to(factor=2.4)
            else:
                view.reset_view()

    def _show_ssd(self) -> None:
        live = self.live
        c = live.location.correspondence if live is not None else None
        if c is None:
            self.criteria_plot.clear_curve()
            self.ssd_note.setText("No SSD search: the marker was not found in the left image.")
        else:
            plain = np.asarray(c.plain_criteria if c.plain_criteria is not None else c.criteria, float)
            second = None
            hits = np.flatnonzero(plain == c.plain_second_minimum) if len(plain) else []
            if len(hits):
                second = (float(c.disparities[hits[0]]), float(c.plain_second_minimum))
            self.criteria_plot.set_curve(c.disparities, plain, minimum=(c.plain_disparity, c.plain_minimum),
                                         second=second, searched=c.criteria if c.warped else None,
                                         disparity=c.disparity)
            self.ssd_note.setText(
                f"Window {c.window[1]}×{c.window[0]} px (the marker's apparent size) on the left reference point, "
                f"slid along the same row of the rectified right image: d* = {c.disparity:.2f} px, reliability "
                f"{c.reliability:.3f} (best / second-best minimum: 0 unique … 1 ambiguous). Below, square windows of "
                "5…37 px at the same point: the lowest criteria grows with the window, which covers more of what "
                "differs between the two views; too small a window sees too little texture and may find its "
                "minimum elsewhere (red), a wrong match.")
        if live is not None and live.sweep is not None:
            s = live.sweep
            located = c.disparity if c is not None and c.ok else None
            self.sweep_plot.set_sweep(s.sizes, s.minima, s.disparities, located)
        else:
            self.sweep_plot.clear_sweep()

    # -- verification ---------------------------------------------------------------------------
    def verify(self, then=None) -> bool:
        locator = self.locator
        if locator is None:
            self._set_status("Train the marker and provide a stereo calibration first.", False)
            return False
        lab = self._current_lab()
        if lab is None:
            return self._build_lab_then(lambda: self.verify(then))
        n = self.verify_spin.value()
        self._verify_count += 1
        self.tabs.setCurrentIndex(TAB_VERIFY)
        return self._start(run_verification, lab, locator, n, int(self.state.seed), self._verify_count,
                           self.stereo.label, self.state.robot_connection, on_result=self._verified,
                           label="Verification", then=then, status=f"Verification over {n} random poses…")

    def _verified(self, v: VerificationResult) -> None:
        self.verification = v
        self._show_verification()
        if v.n_located:
            record = {"kind": "verification", **v.to_dict()}
            self._mark_verified(record)
            self._set_status(f"✓ Verification: {v.n_located} of {v.n} located, median 3D error "
                             f"{_mm(v.median_error)} mm, RMS {_mm(v.rms_error)} mm. The step is done.", True)
        else:
            self._set_status("✗ The marker was not located in any pose: see the reasons.", False)

    def _show_verification(self) -> None:
        v = self.verification
        if v is None:
            self.verify_summary.setText("<span style='color:#5f6368'>The robot visits N random poses where both "
                                        "cameras see the marker; each pair is located and compared with the "
                                        "virtual lab's true marker position.</span>")
            self.precision_plot.clear_points()
            self.progress.setValue(0)
            self.progress.setFormat("%p%")
            return
        self.verify_summary.setText(verification_html(v))
        self.precision_plot.set_points(v.depth, v.errors, v.sigmas)
        self.progress.setValue(1000)
        self.progress.setFormat("done")

    def _mark_verified(self, record: dict) -> None:
        project = self.state.project
        if project is not None and self.saved_path is not None:
            data = {"format": VERIFICATION_FORMAT, "marker": self.saved_path.name, **record}
            try:
                atomic_write_json(verification_file(project), data)
            except RoboCalError as exc:
                self._set_status(f"The verification record was not written: {exc.message}", False)
        was = self.verified
        self.verified = True
        if not was:
            self.notify_complete()

    # -- comparison ---------------------------------------------------------------------------
    def compare(self) -> bool:
        if not self.state.virtual or self.state.robot is None:
            self._set_status("The marker comparison renders its views in the virtual lab.", False)
            return False
        self.tabs.setCurrentIndex(TAB_COMPARE)

        def got(comparison: Comparison):
            self.comparison = comparison
            self._show_comparison()
            result = comparison.result
            best = next(p for p in result.patterns if p.key == result.recommended)
            self._set_status(f"✓ Compared {len(result.patterns)} patterns over {result.views} views: "
                             f"{best.name} detected best ({100 * best.detection_rate:.0f} %).", True)

        kwargs = self._lab_source()
        return self._start(run_comparison, self.compare_spin.value(), int(self.state.seed), on_result=got,
                           label="Comparing markers", status="Comparing the candidate markers…", **kwargs)

    def _show_comparison(self) -> None:
        t = self.compare_table
        if self.comparison is None:
            t.setRowCount(0)
            return
        r, images = self.comparison.result, self.comparison.images
        t.setRowCount(len(r.patterns))
        for i, p in enumerate(r.patterns):
            err = f"{p.median_error:.3f} px" if math.isfinite(p.median_error) else "–"
            cells = [p.name + ("  ★ recommended" if p.key == r.recommended else ""), str(p.training_features),
                     f"{p.mean_matches:.1f}", f"{p.mean_inliers:.1f}", f"{100 * p.detection_rate:.0f} %",
                     str(p.wrong), err]
            tip = p.note + (f"\nNot trained: {p.training_reason}" if p.training_reason else "")
            if p.reasons:
                tip += "\nRejected: " + "; ".join(f"{n}× {k}" for k, n in p.reasons.items())
            for j, text in enumerate(cells):
                item = QTableWidgetItem(text)
                item.setToolTip(tip)
                if j:
                    item.setTextAlignment(Qt.AlignmentFlag.AlignRight | Qt.AlignmentFlag.AlignVCenter)
                if j == 0 and p.key in images:
                    item.setIcon(QIcon(QPixmap.fromImage(to_qimage(images[p.key]))))
                if p.key == r.recommended:
                    f = item.font()
                    f.setBold(True)
                    item.setFont(f)
                t.setItem(i, j, item)


def _crop_around(outline: np.ndarray, w: int, h: int) -> tuple[int, int, int, int]:
    q = np.asarray(outline, dtype=float)
    x0, y0 = q.min(axis=0)
    x1, y1 = q.max(axis=0)
    mx, my = CROP_MARGIN * (x1 - x0), CROP_MARGIN * (y1 - y0)
    return (int(max(0, np.floor(x0 - mx))), int(max(0, np.floor(y0 - my))),
            int(min(w, np.ceil(x1 + mx))), int(min(h, np.ceil(y1 + my))))


def _draw_detection(view: MarkerImageView, det, missing: str = "") -> None:
    """The layers of a core.marker.detection.MarkerDetection on a MarkerImageView."""
    if det is None:
        view.clear_detection()
        view.set_message(missing)
        return
    a, o = det.area, det.outline
    kw = {}
    if a is not None:
        inl = np.asarray(a.inliers, bool)
        kw.update(keypoints=a.keypoints, inliers=a.match_scene[inl] if len(inl) else None,
                  outliers=a.match_scene[~inl] if len(inl) else None, sift_outline=a.outline,
                  sift_reference=a.sift_reference, roi=a.roi)
    if o is not None:
        side = np.asarray(o.edge_side, int)
        edges = np.asarray(o.edge_pixels, float).reshape(-1, 2)
        if len(side) == len(edges):
            kw.update(edges=edges[side >= 0], edges_other=edges[side < 0])
        else:
            kw.update(edges=edges)
        if o.ok:
            kw.update(fitted=o.outline_polyline if o.outline_polyline is not None else o.corners,
                      reference=o.reference, corners=o.corners)
        kw["roi"] = o.roi if o.roi[2] > o.roi[0] else kw.get("roi")
    view.show_detection(message="" if det.ok else f"not found: {det.reason}", **kw)
