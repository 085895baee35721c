"""Step 2, Stereo calibration: checkerboard pairs → a trusted stereo model and stereo.yaml.

Pairs come from two folders (left, right; matched by sorted file name), from the virtual
lab (N pairs at well-spread board poses, rendered and saved as PNGs into the project's
checkerboard/left|right), or from the cameras (live cameras arrive with the hardware issue;
in the virtual lab, one pair from the lab's cameras at a random board pose). Detection runs
on the worker thread in small batches, so thumbnails and the ROS-style coverage bars fill
while pairs are added. Calibration (core.stereo.calibration.calibrate_stereo) runs on the
worker thread too; the page then draws what it returns: the per-pair error bar chart with a
draggable threshold (drop the pairs above it and recalibrate), the parameter table with
standard deviations, the summary figures with an interpretation each, a rectified preview
with horizontal epipolar lines, and the per-corner residual scatter.

The step is complete once a calibration is saved as the project's stereo.yaml (or the
project already has a readable one). The result also goes to ``state.stereo``.
"""
from __future__ import annotations

import html
import math
import re
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from itertools import count
from pathlib import Path
from typing import Callable, Sequence

import cv2
import numpy as np
from PySide6.QtCore import QSize, Qt, QTimer
from PySide6.QtWidgets import (QCheckBox, QComboBox, QDoubleSpinBox, QFileDialog, QGridLayout, QGroupBox,
                               QHBoxLayout, QLabel, QProgressBar, QPushButton, QSpinBox, QSplitter,
                               QTabWidget, QTextBrowser, QVBoxLayout, QWidget)

from app.pages.base import WizardPage
from app.lab import build_lab
from app.pages.steps import Step
from core.stereo.board import Board
from core.stereo.checkerboard import (MIN_BAR, MIN_GOOD_PAIRS, MIN_PAIRS_TO_CALIBRATE, PairDetection, coverage,
                               detect_pair, pair_images, screen_pairs)
from core.errors import RoboCalError
from core.files import atomic_write_bytes
from core.images import load_gray
from core.stereo.calibration import CalibrationOptions, StereoCalibrationResult, calibrate_stereo
from core.stereo.file import read_stereo_yaml, write_ros_camera_info, write_stereo_json, write_stereo_yaml
from core.task import Monitor
from widgets.coverage_bars import CoverageBars
from widgets.error_bar_chart import ErrorBarChart
from widgets.image_view import ImageView
from widgets.residual_scatter import ResidualScatter
from widgets.thumbnail_strip import BAD, MUTED, WARN, ThumbnailStrip, compose_pair_thumbnail
from widgets.value_table import ValueTable

VIRTUAL_PAIRS = 20
RENDER_CHUNK = 4            # pairs rendered per worker task (thumbnails and bars fill in between)
FILE_CHUNK = 6              # pairs detected per worker task when adding folders
THUMB_WIDTH = 100           # px per camera in a thumbnail
LINE_SPACING = 40           # px between the epipolar lines of the rectified preview
PREVIEW_GAP = 8             # px between the rectified left and right images
PNG_PARAMS = [cv2.IMWRITE_PNG_COMPRESSION, 1]
VIRTUAL_TOOLTIP = ("The virtual lab's cameras see its checkerboard at well-spread poses; the images are "
                   "saved into the project (checkerboard/left, checkerboard/right)")
CAMERA_TOOLTIP_HARDWARE = ("Live cameras arrive with the hardware issue. Meanwhile, save pairs with your "
                           "camera software and use Add from folders.")
CAMERA_TOOLTIP_VIRTUAL = ("Virtual lab: take one pair with the lab's two cameras, the board held at a random "
                          "pose. (Live cameras arrive with the hardware issue.)")
BAR_TIPS = {"X": "Spread of the board's horizontal position over the images (ROS camera_calibration's X)",
            "Y": "Spread of the board's vertical position over the images (ROS's Y)",
            "size": "How large the board appears, up to filling the images (ROS's size)",
            "skew": "How much the board is tilted towards and away from the cameras (ROS's skew)"}


# -- the work (plain Python, run on a worker thread) -------------------------------------------
@dataclass
class AddedPair:
    """A pair on the page: its detection (raw verdict, screened again across pairs), the
    thumbnail (row-major RGB), where it came from, and whether the user excluded it."""

    detection: PairDetection
    thumbnail: np.ndarray
    source: str
    key: int = -1
    excluded: bool = False


def _thumbnail(left, right, det: PairDetection, board: Board) -> np.ndarray:
    return compose_pair_thumbnail(left, right, det.left.corners, det.right.corners, board.pattern_size,
                                  found=(bool(det.left.ok or det.left.corners is not None),
                                         bool(det.right.ok or det.right.corners is not None)),
                                  width=THUMB_WIDTH)


def detect_files(pairs: Sequence[tuple[Path, Path]], board: Board, source: str = "folders", *,
                 progress=None, cancelled=None) -> list[AddedPair]:
    """Detect the board in image files (two at a time) and make their thumbnails."""
    monitor = Monitor(progress, cancelled)
    n = len(pairs)

    def work(lr):
        left, right = lr
        det = detect_pair(left, right, board)
        images = [load_gray(p)[0] for p in (left, right)]
        return AddedPair(det, _thumbnail(images[0], images[1], det, board), source)

    out: list[AddedPair] = []
    with ThreadPoolExecutor(max_workers=2) as pool:
        futures = [pool.submit(work, lr) for lr in pairs]
        try:
            for i, fut in enumerate(futures):
                monitor.step(i / max(n, 1), f"detecting the board: pair {i + 1} of {n}")
                out.append(fut.result())
        except BaseException:
            for fut in futures:
                fut.cancel()
            raise
    monitor.step(1.0, "detected")
    return out


def prepare_virtual(lab, robot, seed: int, noise: float, count: int, rng_key: Sequence[int], *,
                    progress=None, cancelled=None):
    """The virtual lab (built when not given) and `count` board poses. Returns (lab, poses)."""
    monitor = Monitor(progress, cancelled)
    if lab is None:
        monitor.step(0.0, "building the virtual lab")
        lab = build_lab(robot, seed, noise)
    monitor.step(0.7, "choosing board poses")
    rng = np.random.default_rng(list(rng_key))
    poses = lab.random_board_poses(count, rng, candidates_per_pose=30 if count > 1 else 4)
    monitor.step(1.0, "ready")
    return lab, poses


def render_pairs(lab, poses: Sequence[np.ndarray], seeds: Sequence[Sequence[int]],
                 paths: Sequence[tuple[Path, Path]], board: Board, source: str = "virtual lab", *,
                 progress=None, cancelled=None) -> list[AddedPair]:
    """Render the lab's checkerboard at each pose, save both images as PNG, detect the board
    (overlapping with the next rendering) and make the thumbnails. A cancelled or failed
    run removes the files it wrote."""
    monitor = Monitor(progress, cancelled)
    n = len(poses)
    written: list[Path] = []
    results = []
    try:
        with ThreadPoolExecutor(max_workers=1) as pool:
            for i, (pose, key, (lp, rp)) in enumerate(zip(poses, seeds, paths)):
                monitor.step(i / max(n, 1), f"rendering pair {i + 1} of {n}")
                left, right = lab.render_checkerboard_pair(pose, np.random.default_rng(list(key)))
                for img, p in ((left, lp), (right, rp)):
                    ok, buf = cv2.imencode(".png", img, PNG_PARAMS)
                    if not ok:
                        raise RoboCalError("could not encode a rendered image as PNG", source=p)
                    atomic_write_bytes(p, buf.tobytes())
                    written.append(Path(p))
                results.append((pool.submit(detect_pair, lp, rp, board), left, right))
            out = []
            for i, (fut, left, right) in enumerate(results):
                monitor.step((i + 0.5) / max(n, 1) * 0.2 + 0.8, "detecting the board")
                det = fut.result()
                out.append(AddedPair(det, _thumbnail(left, right, det, board), source))
    except BaseException:
        for fut, _, _ in results:
            fut.cancel()
        for p in written:
            p.unlink(missing_ok=True)
        raise
    monitor.step(1.0, "rendered")
    return out


def _part(fn: Callable, start: float, stop: float, *args, **kwargs) -> Callable:
    """fn(*args, **kwargs) whose progress covers [start, stop] of a longer job."""
    def job(progress=None, cancelled=None):
        sub = None if progress is None else (lambda f, m="": progress(start + (stop - start) * f, m))
        return fn(*args, progress=sub, cancelled=cancelled, **kwargs)
    return job


# -- text helpers ---------------------------------------------------------------------------
def _esc(text) -> str:
    return html.escape(str(text))


def short_reason(reason: str | None) -> str:
    """A few words for a thumbnail badge (the tool tip has the whole reason)."""
    if not reason:
        return "rejected"
    r = reason.lower()
    for key, text in (("too similar", "too similar"), ("blurred", "blurred"), ("partial board", "partial board"),
                      ("not reliable", "corners unreliable"), ("size mismatch", "size mismatch"),
                      ("differs from the other", "other image size"), ("turned", "left/right order"),
                      ("truncated", "unreadable"), ("not a readable", "unreadable"), ("empty file", "unreadable"),
                      ("not found", "board not found"), ("cannot read", "unreadable")):
        if key in r:
            return text
    return reason[:28]


def _px(v: float | None, digits: int = 3) -> str:
    return "—" if v is None or not math.isfinite(v) else f"{v:.{digits}f} px"


def rms_meaning(v: float) -> str:
    if v < 0.25:
        return "excellent: the model fits every corner to a small fraction of a pixel"
    if v < 0.5:
        return "good: typical of sharp images and a flat board"
    if v < 1.0:
        return "acceptable: look at the pairs with the highest bars (blur, motion, a bent board)"
    return ("poor: check the square size, blurred or moving boards and misdetected pairs "
            "(the highest bars first)")


def epipolar_meaning(rms: float, mx: float) -> str:
    if rms < 0.3 and mx < 1.5:
        return ("matching corners lie on the same row after rectification: a stereo match can be searched "
                "along the row")
    if rms < 1.0:
        return "small vertical offsets remain: usable, but check that the cameras did not move during capture"
    return "large vertical offsets: the cameras moved between pairs, or some pairs are wrong"


def cross_validation_meaning(v: float) -> str:
    if v < 0.5:
        return "the two halves agree — the model is well determined"
    if v < 2.0:
        return ("the two halves differ noticeably: add pairs, especially near the image edges and with "
                "the board tilted")
    return ("the two halves disagree: the model is poorly determined — add pairs with more coverage and "
            "tilt, or use fewer distortion coefficients")


def summary_html(r: StereoCalibrationResult) -> str:
    """The summary figures of a calibration, each with a one-line interpretation."""
    cv = r.cross_validation
    b_std = r.std.get("baseline", float("nan"))
    rows = [
        ("Reprojection RMS, left", _px(r.rms_left), rms_meaning(r.rms_left)),
        ("Reprojection RMS, right", _px(r.rms_right), rms_meaning(r.rms_right)),
        ("Reprojection RMS, stereo", _px(r.rms_stereo),
         rms_meaning(r.rms_stereo) + " (all corners of both cameras in the joint fit)"),
        ("Epipolar error after rectification", f"{_px(r.epipolar_rms)} RMS, {_px(r.epipolar_max)} max",
         epipolar_meaning(r.epipolar_rms, r.epipolar_max)),
    ]
    if cv is not None:
        rows.append(("Cross-validation (two halves)", _px(cv.rms_observed_px),
                     cross_validation_meaning(cv.rms_observed_px)
                     + f" (RMS where the boards were; up to {cv.max_px:.2g} px where no board reached). "
                       f"Their baselines differ by {cv.baseline_diff_mm:.3f} mm"))
    else:
        rows.append(("Cross-validation (two halves)", "not computed",
                     "needs at least 8 pairs: the model's stability is unknown"))
    rows.append(("Baseline |T|", f"{r.baseline_mm:.3f} ± {b_std:.2g} mm",
                 "the distance between the two optical centres: compare it with a ruler between the lenses"))
    out = ['<table cellspacing="0" cellpadding="3">']
    for label, value, meaning in rows:
        out.append(f'<tr><td valign="top"><b>{_esc(label)}</b>&nbsp;&nbsp;</td>'
                   f'<td valign="top" style="white-space:nowrap">{_esc(value)}&nbsp;&nbsp;</td>'
                   f'<td valign="top" style="color:#3c4043">{_esc(meaning)}</td></tr>')
    out.append("</table>")
    used = (f"<p>{r.pairs_used} pairs used, {len(r.rejected)} rejected by detection, {len(r.excluded)} "
            f"dropped by you. Model: {_esc(r.options.describe())}.</p>")
    out.append(used)
    if r.warnings:
        out.append("<p><b>Warnings</b></p><ul>" + "".join(f"<li>{_esc(w)}</li>" for w in r.warnings) + "</ul>")
    return "".join(out)


def residual_stats_html(r: StereoCalibrationResult) -> str:
    """RMS of the residuals along x and y, mean (bias) and largest, per camera (px)."""
    cols = []
    for res in (r.residuals_left, r.residuals_right):
        e = res.reshape(-1, 2)
        e = e[np.all(np.isfinite(e), axis=1)]
        if not len(e):
            cols.append(["—"] * 5)
            continue
        rms = np.sqrt(np.mean(e ** 2, axis=0))
        mean = np.round(e.mean(axis=0), 3) + 0.0      # no "-0.000"
        worst = float(np.max(np.hypot(e[:, 0], e[:, 1])))
        cols.append([f"{rms[0]:.3f}", f"{rms[1]:.3f}", f"{mean[0]:+.3f}", f"{mean[1]:+.3f}", f"{worst:.3f}"])
    names = ["RMS x", "RMS y", "mean x", "mean y", "largest"]
    rows = "".join(f"<tr><td>{n}</td><td align='right'>{a}</td><td align='right'>{b}</td></tr>"
                   for n, a, b in zip(names, *cols))
    return ("<table cellspacing='0' cellpadding='2'><tr><th align='left'>px</th><th align='right'>left</th>"
            "<th align='right'>&nbsp;right</th></tr>" + rows + "</table>"
            "<p style='color:#5f6368'>The means should be close to 0 (no bias) and RMS x close to RMS y. "
            "The largest is usually 3–4× the RMS; much more points to one bad corner or pair "
            "(see Errors per pair).</p>")


PARAM_NAMES = {"fx": "fx (focal length)", "fy": "fy (focal length)", "cx": "cx (principal point)",
               "cy": "cy (principal point)", "k1": "k1 (radial)", "k2": "k2 (radial)", "k3": "k3 (radial)",
               "k4": "k4 (rational)", "k5": "k5 (rational)", "k6": "k6 (rational)", "p1": "p1 (tangential)",
               "p2": "p2 (tangential)", "rx": "R: rx (rotation vector)", "ry": "R: ry (rotation vector)",
               "rz": "R: rz (rotation vector)", "tx": "T: tx", "ty": "T: ty", "tz": "T: tz",
               "baseline": "baseline |T|"}
GROUP_NAMES = {"left": "Left camera", "right": "Right camera", "stereo": "Right from left"}
UNIT_NAMES = {"deg": "°"}


# -- the page -------------------------------------------------------------------------------
class StereoPage(WizardPage):
    step = Step.STEREO

    def __init__(self, state, tasks, **kwargs):
        super().__init__(state, tasks, **kwargs)
        self.items: list[AddedPair] = []
        self.detections = None                     # DetectionResult of self.items (screened)
        self.result: StereoCalibrationResult | None = None
        self.result_stale = False                  # pairs changed since the calibration
        self.saved_path: Path | None = None        # stereo.yaml of this session or found in the project
        self.ignored_files: list[str] = []
        self._keys = count()
        self._lab = None
        self._handle = None
        self._queue: list[tuple[Callable, str]] = []
        self._queue_total = 0
        self._queue_done = 0
        self._queue_then: Callable[[], None] | None = None
        self._token = 0
        self._preview_token = 0                     # the latest preview asked for
        self._after_adding_note = ""
        self._board = self._default_board()

        # -- pairs ----------------------------------------------------------------------
        self.folders_button = QPushButton("Add from folders…")
        self.folders_button.setObjectName("foldersButton")
        self.folders_button.setToolTip("Choose the left camera's folder, then the right camera's; images are "
                                       "paired by sorted file name")
        self.folders_button.clicked.connect(lambda: self.add_folders_dialog())
        self.virtual_button = QPushButton("Render virtual-lab pairs")
        self.virtual_button.setObjectName("virtualButton")
        self.virtual_button.clicked.connect(lambda: self.add_virtual_pairs(self.virtual_count.value()))
        self.virtual_count = QSpinBox()
        self.virtual_count.setRange(1, 60)
        self.virtual_count.setValue(VIRTUAL_PAIRS)
        self.virtual_count.setSuffix(" pairs")
        self.capture_button = QPushButton("Capture from cameras")
        self.capture_button.setObjectName("captureButton")
        self.capture_button.clicked.connect(lambda: self.capture_pair())
        self.remove_button = QPushButton("Remove")
        self.remove_button.setToolTip("Remove the selected pairs from the calibration (files stay on disk)")
        self.remove_button.clicked.connect(lambda: self.remove_pairs(self.strip.selected_keys()))
        self.clear_button = QPushButton("Clear")
        self.clear_button.setToolTip("Remove every pair from the page (files stay on disk)")
        self.clear_button.clicked.connect(lambda: self.clear_pairs())

        self.cols_spin = QSpinBox()
        self.cols_spin.setRange(2, 60)
        self.rows_spin = QSpinBox()
        self.rows_spin.setRange(2, 60)
        self.square_spin = QDoubleSpinBox()
        self.square_spin.setRange(0.1, 1000.0)
        self.square_spin.setDecimals(2)
        self.square_spin.setSuffix(" mm")
        for w, tip in ((self.cols_spin, "Inner corners along a row of the board (squares − 1)"),
                       (self.rows_spin, "Inner corners along a column of the board (squares − 1)"),
                       (self.square_spin, "Side of one square, measured on the printed board")):
            w.setToolTip(tip)
        self._set_board_widgets(self._board)
        self._board_timer = QTimer(self)
        self._board_timer.setSingleShot(True)
        self._board_timer.setInterval(600)
        self._board_timer.timeout.connect(self.apply_board)
        for w in (self.cols_spin, self.rows_spin, self.square_spin):
            w.valueChanged.connect(lambda *_: self._board_timer.start())

        self.strip = ThumbnailStrip(icon_size=QSize(2 * THUMB_WIDTH + 4, int(THUMB_WIDTH * 0.8)))
        self.strip.currentKeyChanged.connect(self._thumbnail_picked)
        self.strip.itemSelectionChanged.connect(self._update_buttons)
        self.count_label = QLabel()
        self.count_label.setObjectName("countLabel")
        self.coverage_bars = CoverageBars(("X", "Y", "size", "skew"), threshold=MIN_BAR, tooltips=BAR_TIPS,
                                          labels={"size": "Size", "skew": "Skew"})
        self.advice = QLabel()
        self.advice.setObjectName("adviceLabel")
        self.advice.setWordWrap(True)

        row1 = QHBoxLayout()
        row1.addWidget(self.folders_button)
        row1.addWidget(self.virtual_button)
        row1.addWidget(self.virtual_count)
        row1.addWidget(self.capture_button)
        row1.addStretch(1)
        row2 = QHBoxLayout()
        row2.addWidget(QLabel("Board:"))
        row2.addWidget(self.cols_spin)
        row2.addWidget(QLabel("×"))
        row2.addWidget(self.rows_spin)
        row2.addWidget(QLabel("inner corners, square"))
        row2.addWidget(self.square_spin)
        row2.addStretch(1)
        row2.addWidget(self.remove_button)
        row2.addWidget(self.clear_button)
        pairs_box = QGroupBox("Checkerboard pairs")
        pl = QVBoxLayout(pairs_box)
        pl.setSpacing(4)
        pl.addLayout(row1)
        pl.addLayout(row2)
        pl.addWidget(self.strip)
        cov = QHBoxLayout()
        cov.addWidget(QLabel("Coverage:"))
        cov.addWidget(self.coverage_bars, 1)
        pl.addLayout(cov)
        arow = QHBoxLayout()
        arow.addWidget(self.count_label, 0, Qt.AlignmentFlag.AlignTop)
        arow.addWidget(self.advice, 1)
        pl.addLayout(arow)

        # -- options and calibration ----------------------------------------------------
        self.radial_combo = QComboBox()
        self.radial_combo.addItem("2: k1 k2", 2)
        self.radial_combo.addItem("3: k1 k2 k3", 3)
        self.radial_combo.addItem("6: rational", 6)
        self.radial_combo.setCurrentIndex(1)
        self.radial_combo.setToolTip("Radial distortion coefficients: 2 for narrow lenses, 3 usually, 6 for "
                                     "strong wide-angle distortion (needs many well-spread pairs)")
        self.tangential_check = QCheckBox("tangential")
        self.tangential_check.setChecked(True)
        self.tangential_check.setToolTip("Estimate the tangential coefficients p1, p2: decentring distortion of a lens "
                                         "not exactly square to the sensor")
        self.aspect_check = QCheckBox("fx = fy")
        self.aspect_check.setToolTip("Fix the aspect ratio: keep fx = fy (square pixels)")
        self.principal_check = QCheckBox("fix centre")
        self.principal_check.setToolTip("Fix the principal point: keep (cx, cy) at the image centre: steadier with few or poorly spread "
                                        "pairs")
        self.calibrate_button = QPushButton("Calibrate")
        self.calibrate_button.setObjectName("calibrateButton")
        self.calibrate_button.setDefault(True)
        self.calibrate_button.clicked.connect(lambda: self.calibrate())
        self.cancel_button = QPushButton("Cancel")
        self.cancel_button.setObjectName("cancelButton")
        self.cancel_button.clicked.connect(self.cancel)
        self.progress = QProgressBar()
        self.progress.setRange(0, 1000)
        self.progress.setTextVisible(True)
        self.progress.setFormat("")
        self.progress.setVisible(False)
        options_box = QWidget()
        options_box.setObjectName("optionsRow")
        ol = QGridLayout(options_box)
        ol.setContentsMargins(0, 0, 0, 0)
        ol.setHorizontalSpacing(8)
        orow = QHBoxLayout()
        model = QLabel("Camera model")
        model.setObjectName("sectionHeading")
        orow.addWidget(model)
        orow.addSpacing(6)
        orow.addWidget(QLabel("radial:"))
        orow.addWidget(self.radial_combo)
        orow.addWidget(self.tangential_check)
        orow.addWidget(self.aspect_check)
        orow.addWidget(self.principal_check)
        orow.addStretch(1)
        orow.addWidget(self.calibrate_button)
        orow.addWidget(self.cancel_button)
        ol.addLayout(orow, 0, 0)
        ol.addWidget(self.progress, 1, 0)

        # -- results --------------------------------------------------------------------
        self.errors_chart = ErrorBarChart()
        self.errors_chart.selectionChanged.connect(self._threshold_selection)
        self.drop_button = QPushButton("Drop selected && recalibrate")
        self.drop_button.setObjectName("dropButton")
        self.drop_button.setToolTip("Drag the black line down: pairs with a bar above it are dropped")
        self.drop_button.clicked.connect(lambda: self.drop_selected())
        self.flagged_button = QPushButton("Select flagged")
        self.flagged_button.setToolTip("Move the line just below the pairs flagged as outliers")
        self.flagged_button.clicked.connect(self.select_flagged)
        self.restore_button = QPushButton("Restore dropped")
        self.restore_button.setToolTip("Bring back every pair you dropped (then Calibrate again)")
        self.restore_button.clicked.connect(self.restore_excluded)
        self.outlier_label = QLabel()
        self.outlier_label.setObjectName("hint")
        self.outlier_label.setWordWrap(True)
        errors_tab = QWidget()
        el = QVBoxLayout(errors_tab)
        el.setContentsMargins(4, 4, 4, 4)
        el.addWidget(self.errors_chart, 1)
        erow = QHBoxLayout()
        erow.addWidget(self.outlier_label, 1)
        erow.addWidget(self.flagged_button)
        erow.addWidget(self.restore_button)
        erow.addWidget(self.drop_button)
        el.addLayout(erow)

        self.table = ValueTable(group_names=GROUP_NAMES, display_names=PARAM_NAMES, unit_names=UNIT_NAMES)
        self.table.setObjectName("stereoParameterTable")
        self.summary_view = QTextBrowser()
        self.summary_view.setObjectName("summaryView")
        self.summary_view.setOpenLinks(False)

        self.preview = ImageView()
        self.preview.add_lines("epipolar", colour="#34a853", width=1.0)
        self.preview.add_points("left_corners", colour="#ea4335", symbol="o", size=4, width=0)
        self.preview.add_points("right_corners", colour="#ea4335", symbol="o", size=4, width=0)
        self.preview_combo = QComboBox()
        self.preview_combo.setObjectName("previewCombo")
        self.preview_combo.setMinimumContentsLength(24)
        self.preview_combo.currentIndexChanged.connect(self._preview_changed)
        self.preview_caption = QLabel()
        self.preview_caption.setObjectName("hint")
        self.preview_caption.setWordWrap(True)
        preview_tab = QWidget()
        pvl = QVBoxLayout(preview_tab)
        pvl.setContentsMargins(4, 4, 4, 4)
        prow = QHBoxLayout()
        prow.addWidget(QLabel("Pair:"))
        prow.addWidget(self.preview_combo)
        prow.addWidget(self.preview_caption, 1)
        pvl.addLayout(prow)
        pvl.addWidget(self.preview, 1)

        self.scatter = ResidualScatter()
        self.scatter_caption = QLabel()
        self.scatter_caption.setObjectName("hint")
        self.scatter_caption.setWordWrap(True)
        self.scatter_stats = QLabel()
        self.scatter_stats.setObjectName("scatterStats")
        self.scatter_stats.setAlignment(Qt.AlignmentFlag.AlignTop | Qt.AlignmentFlag.AlignLeft)
        self.scatter_stats.setWordWrap(True)
        self.scatter_stats.setTextInteractionFlags(Qt.TextInteractionFlag.TextSelectableByMouse)
        scatter_tab = QWidget()
        sl = QVBoxLayout(scatter_tab)
        sl.setContentsMargins(4, 4, 4, 4)
        srow = QHBoxLayout()
        srow.addWidget(self.scatter, 3)
        srow.addWidget(self.scatter_stats, 2)
        sl.addLayout(srow, 1)
        sl.addWidget(self.scatter_caption)

        self.tabs = QTabWidget()
        self.tabs.setObjectName("resultTabs")
        self.tabs.addTab(errors_tab, "Errors per pair")
        self.tabs.addTab(self.summary_view, "Summary")
        self.table_note = QLabel(
            "<b>± σ</b> is one standard deviation of each parameter, from the Jacobian of the joint fit "
            "(eq. 21). Small σ of f<sub>x</sub>, f<sub>y</sub>, c<sub>x</sub>, c<sub>y</sub> and k<sub>1</sub> "
            "matters more than a low RMS. A σ as large as its value (often k<sub>3</sub>) means the pairs do "
            "not determine that coefficient: add tilted views near the image edges, or estimate fewer "
            "coefficients.<br><br>R is given as a rotation vector (axis × angle, degrees); T and the "
            "baseline in mm, X<sub>right</sub> = R·X<sub>left</sub> + T. Greyed values were fixed.")
        self.table_note.setObjectName("hint")
        self.table_note.setWordWrap(True)
        self.table_note.setAlignment(Qt.AlignmentFlag.AlignTop | Qt.AlignmentFlag.AlignLeft)
        table_tab = QWidget()
        ttl = QHBoxLayout(table_tab)
        ttl.setContentsMargins(4, 4, 4, 4)
        ttl.addWidget(self.table, 3)
        ttl.addWidget(self.table_note, 2)
        self.tabs.addTab(table_tab, "Parameters ± σ")
        self.tabs.addTab(preview_tab, "Rectified pair")
        self.tabs.addTab(scatter_tab, "Residuals")

        # -- save and exports -----------------------------------------------------------
        self.save_button = QPushButton("Save stereo.yaml")
        self.save_button.setObjectName("saveButton")
        self.save_button.setToolTip("Accept this calibration: write stereo.yaml into the project folder "
                                    "(atomically: a failure leaves the previous file as it was)")
        self.save_button.clicked.connect(lambda: self.save_stereo())
        self.ros_button = QPushButton("ROS camera_info…")
        self.ros_button.setToolTip("Write left.yaml and right.yaml (ROS camera_info) into a folder")
        self.ros_button.clicked.connect(lambda: self.export_ros())
        self.json_button = QPushButton("JSON…")
        self.json_button.setToolTip("Write the calibration, its parameter table and per-pair errors as JSON")
        self.json_button.clicked.connect(lambda: self.export_json())
        self.status.setTextInteractionFlags(Qt.TextInteractionFlag.TextSelectableByMouse)
        xrow = QHBoxLayout()
        xrow.addStretch(1)
        xrow.addWidget(self.save_button)
        xrow.addWidget(QLabel("Export:"))
        xrow.addWidget(self.ros_button)
        xrow.addWidget(self.json_button)

        top = QWidget()
        tl = QVBoxLayout(top)
        tl.setContentsMargins(0, 0, 0, 0)
        tl.setSpacing(6)
        tl.addWidget(pairs_box)
        tl.addWidget(options_box)
        self.splitter = QSplitter(Qt.Orientation.Vertical)
        self.splitter.addWidget(top)
        self.splitter.addWidget(self.tabs)
        self.splitter.setStretchFactor(0, 0)
        self.splitter.setStretchFactor(1, 1)
        self.splitter.setChildrenCollapsible(False)
        layout = QVBoxLayout(self)
        layout.setContentsMargins(0, 0, 0, 0)
        layout.setSpacing(6)
        layout.addWidget(self.splitter, 1)
        layout.addWidget(self.status)
        layout.addLayout(xrow)

        state.projectChanged.connect(self._context_changed)
        state.labChanged.connect(self._lab_changed)
        self._context_changed()

    # -- state ------------------------------------------------------------------------------
    @property
    def busy(self) -> bool:
        return self._handle is not None

    @property
    def board(self) -> Board:
        return self._board

    def options(self) -> CalibrationOptions:
        return CalibrationOptions(radial=int(self.radial_combo.currentData()),
                                  tangential=self.tangential_check.isChecked(),
                                  fix_aspect=self.aspect_check.isChecked(),
                                  fix_principal=self.principal_check.isChecked())

    def usable_pairs(self) -> list[AddedPair]:
        return [a for a in self.items if a.detection.accepted and not a.excluded]

    def _default_board(self) -> Board:
        if self.state.virtual:
            if self._lab is not None:
                return self._lab.board
            try:
                from app.lab import DEFAULT_BOARD
                return DEFAULT_BOARD
            except ImportError:
                pass
        return Board(9, 6, 24.0)

    def _set_board_widgets(self, board: Board) -> None:
        for w, v in ((self.cols_spin, board.cols), (self.rows_spin, board.rows), (self.square_spin, board.square)):
            w.blockSignals(True)
            w.setValue(v)
            w.blockSignals(False)

    def _lab_changed(self, lab) -> None:
        self._lab = lab

    def _context_changed(self, *_) -> None:
        """Another project: pairs, result and lab no longer apply."""
        self._token += 1
        self._stop_tasks()
        self.items.clear()
        self.strip.clear_all()
        self.detections = None
        self.result = None
        self.result_stale = False
        self.saved_path = None
        self.ignored_files = []
        self._board = self._default_board()
        self._set_board_widgets(self._board)
        project = self.state.project
        message, ok = "", False
        if project is not None and project.has("stereo"):
            path = project.path("stereo")
            try:
                sf = read_stereo_yaml(path)
            except RoboCalError as exc:
                message = f"The project's stereo.yaml cannot be used ({exc.message}). Calibrate again."
            else:
                self.saved_path = path
                ok = True
                self._board = sf.board                   # the board those pairs show
                self._set_board_widgets(self._board)
                message = (f"This project already has {path.name} (stereo RMS {sf.rms_stereo:.3f} px, baseline "
                           f"{sf.baseline_mm:.1f} mm, {sf.image_size[0]}x{sf.image_size[1]}): the step is done. "
                           "Add pairs and calibrate to replace it.")
        elif project is None:
            message = "No project yet: create or open one in the Setup step (1)."
        self._refresh_pairs()
        self._show_result()
        self._set_status(message, ok=ok)
        self.notify_complete()
        saved = project.folder / "checkerboard" if project is not None else None
        if saved is not None and any((saved / "left").glob("*.png")) and any((saved / "right").glob("*.png")):
            # pairs rendered or captured into this project earlier: back on the page
            self.add_folders(saved / "left", saved / "right",
                             then=lambda: self._set_status(message + " The project's saved pairs are back.", ok=ok))

    # -- WizardPage ---------------------------------------------------------------------------
    def on_enter(self) -> None:
        self._update_buttons()

    def on_leave(self) -> None:
        if self._board_timer.isActive():
            self.apply_board()

    def is_complete(self) -> bool:
        return self.saved_path is not None and self.saved_path.is_file()

    def autopilot(self, done) -> None:
        if self.state.project is None:
            done(False, "no project (Setup step)")
            return
        if self.busy:
            done(False, "the page is busy")
            return
        self._autopilot_done = done
        if self.result is not None and not self.result_stale:
            self._autopilot_save()
            return
        if len(self.usable_pairs()) >= MIN_PAIRS_TO_CALIBRATE and (
                self.detections is not None and self.detections.coverage.enough):
            if not self.calibrate():
                self._finish_autopilot(False, self.status.text() or "calibration could not start")
            return
        if not self.state.virtual:
            self._finish_autopilot(False, "no checkerboard pairs: add pairs from folders first")
            return
        lab_board = self._default_board()
        if lab_board != self._board:          # the lab's board: pairs of another board cannot join
            self.clear_pairs()
            self.set_board(lab_board)
        if not self.add_virtual_pairs(VIRTUAL_PAIRS, then=self._autopilot_calibrate):
            self._finish_autopilot(False, self.status.text() or "could not render the virtual-lab pairs")

    def _autopilot_calibrate(self) -> None:
        if self._autopilot_done is None:
            return
        if len(self.usable_pairs()) < MIN_PAIRS_TO_CALIBRATE or not self.calibrate():
            self._finish_autopilot(False, self.status.text() or "too few usable pairs")

    def _autopilot_save(self) -> None:
        if self._autopilot_done is None:
            return
        path = self.save_stereo()
        if path is None:
            self._finish_autopilot(False, self.status.text() or "stereo.yaml could not be written")
        else:
            r = self.result
            self._finish_autopilot(True, f"{r.pairs_used} pairs, stereo RMS {r.rms_stereo:.3f} px, "
                                         f"baseline {r.baseline_mm:.1f} mm")

    # -- tasks: a queue of worker jobs run one after the other ----------------------------------
    def _run_queue(self, jobs: list[tuple[Callable, str]], then: Callable[[], None] | None = None) -> None:
        self._queue = list(jobs)
        self._queue_total = len(jobs)
        self._queue_done = 0
        self._queue_then = then
        self._next_job()

    def _next_job(self) -> None:
        if not self._queue:
            then, self._queue_then = self._queue_then, None
            self._handle = None
            self._set_busy(False)
            if then is not None:
                then()
            return
        fn, label = self._queue.pop(0)
        token = self._token
        self._handle = self.run_task(
            fn, on_result=lambda value: self._job_done(token, value),
            on_error=lambda msg: self._job_failed(token, msg),
            on_cancelled=lambda: self._job_cancelled(token),
            on_progress=self._job_progress, label=label)
        self._set_busy(True, label)

    def _job_progress(self, fraction: float, message: str) -> None:
        total = max(self._queue_total, 1)
        overall = (self._queue_done + min(max(fraction, 0.0), 1.0)) / total
        self.progress.setValue(int(round(1000 * overall)))
        self.progress.setFormat(f"{message.replace('%', '%%')}  %p%" if message else "%p%")

    def _job_done(self, token: int, value) -> None:
        if token != self._token:
            return
        self._queue_done += 1
        if isinstance(value, _Continue):
            value.then()
        elif isinstance(value, list):
            self._add(value)
        elif isinstance(value, StereoCalibrationResult):
            self._calibrated(value)
        if self._handle is not None:
            self._next_job()

    def _job_failed(self, token: int, message: str) -> None:
        if token != self._token:
            return
        self._abort_queue()
        self._set_status(message, ok=False)
        self._finish_autopilot(False, message)

    def _job_cancelled(self, token: int) -> None:
        if token != self._token:
            return
        self._abort_queue()
        kept = len(self.items)
        self._set_status(f"Cancelled. {kept} pair{'s' if kept != 1 else ''} on the page.", ok=False)
        self._finish_autopilot(False, "cancelled")

    def _abort_queue(self) -> None:
        self._queue.clear()
        self._queue_then = None
        self._handle = None
        self._set_busy(False)

    def cancel(self) -> None:
        if self._handle is not None:
            self._queue.clear()
            self._queue_then = None
            self._handle.cancel()

    def _stop_tasks(self) -> None:
        if self._handle is not None:
            self._handle.cancel()
        self._queue.clear()
        self._queue_then = None
        self._handle = None
        self._set_busy(False)

    def _set_busy(self, busy: bool, label: str = "") -> None:
        self.progress.setVisible(busy)
        if busy:
            self.progress.setValue(int(round(1000 * self._queue_done / max(self._queue_total, 1))))
            self.progress.setFormat(f"{label}…")
        self._update_buttons()

    def _update_buttons(self) -> None:
        busy = self.busy
        has_project = self.state.project is not None
        virtual = self.state.virtual
        for w in (self.folders_button, self.cols_spin, self.rows_spin, self.square_spin):
            w.setEnabled(not busy and has_project)
        self.virtual_button.setEnabled(not busy and has_project and virtual)
        self.virtual_count.setEnabled(not busy and has_project and virtual)
        self.virtual_button.setToolTip(VIRTUAL_TOOLTIP if virtual else "Only in a virtual-lab project")
        self.capture_button.setEnabled(not busy and has_project and virtual)
        self.capture_button.setToolTip(CAMERA_TOOLTIP_VIRTUAL if virtual else CAMERA_TOOLTIP_HARDWARE)
        self.remove_button.setEnabled(not busy and bool(self.strip.selectedItems()))
        self.clear_button.setEnabled(not busy and bool(self.items))
        usable = len(self.usable_pairs())
        self.calibrate_button.setEnabled(not busy and usable >= MIN_PAIRS_TO_CALIBRATE)
        enough = self.detections is not None and self._coverage().enough
        self.calibrate_button.setText("Calibrate" if enough or usable < MIN_PAIRS_TO_CALIBRATE
                                      else "Calibrate (low coverage)")
        self.calibrate_button.setToolTip(
            f"Needs at least {MIN_PAIRS_TO_CALIBRATE} accepted pairs" if usable < MIN_PAIRS_TO_CALIBRATE else
            ("Enough views: calibrate" if enough else
             "Possible, but coverage is not enough yet: the result may be poorly determined"))
        self.cancel_button.setEnabled(busy)
        has_result = self.result is not None
        for w in (self.radial_combo, self.tangential_check, self.aspect_check, self.principal_check):
            w.setEnabled(not busy)
        self.save_button.setEnabled(not busy and has_result and has_project)
        self.ros_button.setEnabled(not busy and has_result)
        self.json_button.setEnabled(not busy and has_result)
        self.drop_button.setEnabled(not busy and has_result and bool(self.errors_chart.selected()))
        self.flagged_button.setEnabled(not busy and has_result and bool(self.result.outliers if has_result else []))
        self.restore_button.setEnabled(not busy and any(a.excluded for a in self.items))

    # -- adding pairs ---------------------------------------------------------------------------
    def _need_project(self) -> bool:
        if self.state.project is None:
            self._set_status("No project yet: create or open one in the Setup step (1).", ok=False)
            return False
        if self.busy:
            self._set_status("Busy: wait for the running task or cancel it.", ok=False)
            return False
        return True

    def add_folders_dialog(self) -> bool:
        start = str(self.state.project.folder) if self.state.project is not None else ""
        left = QFileDialog.getExistingDirectory(self, "Folder of the LEFT camera's images", start)
        if not left:
            return False
        right = QFileDialog.getExistingDirectory(self, "Folder of the RIGHT camera's images", str(Path(left).parent))
        if not right:
            return False
        return self.add_folders(left, right)

    def add_folders(self, left, right, then: Callable[[], None] | None = None) -> bool:
        """Pair the images of two folders by sorted name and detect them on the worker thread.
        Problems with the folders (unequal counts, no images) are shown on the page."""
        if not self._need_project():
            return False
        try:
            pairs, ignored = pair_images(left, right)
        except RoboCalError as exc:
            self._set_status(f"Cannot add these folders: {exc.message}", ok=False)
            return False
        self.ignored_files = list(ignored)
        board = self._board
        jobs = []
        n = len(pairs)
        for start in range(0, n, FILE_CHUNK):
            chunk = pairs[start:start + FILE_CHUNK]
            jobs.append((_part(detect_files, 0.0, 1.0, chunk, board, "folders"), "Detecting checkerboards"))
        note = ""
        if ignored:
            shown = ", ".join(ignored[:4]) + (", …" if len(ignored) > 4 else "")
            note = f" Not images, ignored: {shown}."
        self._set_status(f"Detecting the board in {n} pair{'s' if n != 1 else ''}…{note}")
        self._after_adding_note = note
        self._run_queue(jobs, then=lambda: self._adding_finished(then))
        return True

    def add_virtual_pairs(self, n: int = VIRTUAL_PAIRS, then: Callable[[], None] | None = None, *,
                          source: str = "virtual lab") -> bool:
        """Render n pairs of the virtual lab's checkerboard (saved into the project), detect them."""
        if not self._need_project():
            return False
        if not self.state.virtual:
            self._set_status("The virtual lab is only available in a virtual-lab project.", ok=False)
            return False
        folder = self.state.project.folder / "checkerboard"
        first = _next_free_number(folder)
        seed, noise = int(self.state.seed), float(self.state.noise)
        lab = self._lab
        self._after_adding_note = ""

        def prepared(value):
            lab_, poses = value
            self._lab = lab_
            self.state.adopt_lab(lab_)
            board = self._board
            paths = [(folder / "left" / f"pair_{first + i:03d}.png", folder / "right" / f"pair_{first + i:03d}.png")
                     for i in range(len(poses))]
            seeds = [[seed, 11, first + i] for i in range(len(poses))]
            jobs = []
            for s in range(0, len(poses), RENDER_CHUNK):
                jobs.append((_part(render_pairs, 0.0, 1.0, lab_, poses[s:s + RENDER_CHUNK], seeds[s:s + RENDER_CHUNK],
                                   paths[s:s + RENDER_CHUNK], board, source), "Rendering virtual-lab pairs"))
            self._queue[:0] = jobs
            self._queue_total += len(jobs)

        prepare = _part(prepare_virtual, 0.0, 1.0, lab, self.state.robot, seed, noise, int(n), [seed, 10, first])
        self._set_status(f"Rendering {n} virtual-lab pair{'s' if n != 1 else ''}…")
        self._run_queue([(_then(prepare, prepared), "Preparing the virtual lab")],
                        then=lambda: self._adding_finished(then))
        return True

    def capture_pair(self) -> bool:
        """Live cameras arrive with the hardware issue; the virtual lab's cameras take one pair
        with the board at a random pose."""
        if not self.state.virtual:
            self._set_status(CAMERA_TOOLTIP_HARDWARE, ok=False)
            return False
        return self.add_virtual_pairs(1, source="virtual camera")

    def _adding_finished(self, then: Callable[[], None] | None) -> None:
        self._report_pairs(getattr(self, "_after_adding_note", ""))
        if then is not None:
            then()

    def _add(self, added: list[AddedPair]) -> None:
        """New pairs from a worker: screened again with the others, shown, coverage updated."""
        for a in added:
            a.key = next(self._keys)
            self.items.append(a)
            self.strip.add(a.key, a.thumbnail, "")
        self._changed()

    def remove_pairs(self, keys: Sequence[int]) -> None:
        if self.busy or not keys:
            return
        gone = set(keys)
        for a in [a for a in self.items if a.key in gone]:
            self.items.remove(a)
            self.strip.remove(a.key)
        self._changed()
        self._report_pairs()

    def clear_pairs(self) -> None:
        if self.busy:
            return
        self.items.clear()
        self.strip.clear_all()
        self._changed()
        self._report_pairs()

    def set_board(self, board: Board) -> None:
        self._set_board_widgets(board)
        self.apply_board()

    def apply_board(self) -> None:
        """The board definition changed: redetect every pair when the corner grid changed,
        or only screen them again when the square size changed."""
        self._board_timer.stop()
        new = Board(self.cols_spin.value(), self.rows_spin.value(), float(self.square_spin.value()))
        if new == self._board:
            return
        if self.busy:                      # after the running task
            self._board_timer.start()
            return
        old, self._board = self._board, new
        if not self.items:
            self._changed()
            return
        if (old.cols, old.rows) == (new.cols, new.rows):
            self._changed()
            self._set_status(f"Square size {new.square:g} mm: calibrate again to use it.")
            return
        pairs = [(Path(a.detection.left_path), Path(a.detection.right_path), a.source) for a in self.items]
        self.items.clear()
        self.strip.clear_all()
        self._changed()
        jobs = []
        for s in range(0, len(pairs), FILE_CHUNK):
            chunk = pairs[s:s + FILE_CHUNK]
            jobs.append((_sources(_part(detect_files, 0.0, 1.0, [(l, r) for l, r, _ in chunk], new),
                                  [src for _, _, src in chunk]), "Detecting checkerboards"))
        self._set_status(f"Board {new.cols}x{new.rows}: detecting the board again in {len(pairs)} pairs…")
        self._after_adding_note = ""
        self._run_queue(jobs, then=lambda: self._adding_finished(None))

    def _coverage(self):
        return coverage([a.detection for a in self.usable_pairs()])

    def _changed(self) -> None:
        """Pairs or board changed: screen all pairs again, redraw thumbnails and bars."""
        dets = [a.detection for a in self.items]
        self.detections = screen_pairs(dets, self._board) if dets else None
        if self.result is not None:
            self.result_stale = True
        self._refresh_pairs()

    def _refresh_pairs(self) -> None:
        r = self.result if not self.result_stale else None
        rms = {}
        if r is not None:
            rms = {i: v for i, v in zip(r.view_indices, r.per_view_rms)}
        for a in self.items:
            d = a.detection
            n = d.index + 1
            tip = [f"Pair {n}: {d.name}", f"from the {a.source}"]
            if a.excluded:
                badge, colour, caption = "dropped by you", MUTED, f"{n}  dropped"
                tip.append("Dropped from the calibration (Restore dropped brings it back)")
            elif not d.accepted:
                badge, colour, caption = short_reason(d.reason), BAD, f"{n}  ✗"
                tip.append(f"Rejected: {d.reason}")
            else:
                badge, colour, caption = None, BAD, f"{n}  ✓"
                if r is not None and d.index in rms:
                    caption = f"{n}  ✓ {rms[d.index]:.3f} px"
                    if d.index in r.outliers:
                        badge, colour = "outlier", WARN
                        tip.append(f"Flagged as an outlier: RMS {rms[d.index]:.3f} px > "
                                   f"{r.outlier_threshold:.3f} px")
            self.strip.update(a.key, caption=caption, badge=badge, badge_colour=colour, tooltip="\n".join(tip))
        total = len(self.items)
        accepted = sum(1 for a in self.items if a.detection.accepted)
        dropped = sum(1 for a in self.items if a.excluded)
        self.count_label.setText(f"<b>{total} pairs</b>: {accepted} accepted, {total - accepted} rejected"
                                 + (f", {dropped} dropped" if dropped else "") + ".")
        cov = self._coverage()
        self.coverage_bars.set_values(cov.bars)
        usable = len(self.usable_pairs())
        if cov.enough:
            text = (f"<span style='color:#188038'><b>Enough views</b></span> ({usable} pairs, every bar ≥ "
                    f"{MIN_BAR}): calibrate.")
        elif usable >= MIN_PAIRS_TO_CALIBRATE:
            text = (f"<span style='color:#b06000'><b>Not enough views yet</b></span> — calibrating is possible "
                    f"from {MIN_PAIRS_TO_CALIBRATE} pairs, but the result may be poorly determined. "
                    + "; ".join(_esc(a) for a in cov.advice) + ".")
        else:
            text = ("<b>Add pairs</b>: " + "; ".join(_esc(a) for a in cov.advice)
                    + f". At least {MIN_GOOD_PAIRS} well-spread pairs with every bar ≥ {MIN_BAR}.")
        self.advice.setText(text)
        self._update_buttons()

    def _report_pairs(self, note: str = "") -> None:
        total = len(self.items)
        rejected = [a.detection for a in self.items if not a.detection.accepted]
        text = f"{total} pair{'s' if total != 1 else ''} on the page"
        if rejected:
            shown = "; ".join(f"pair {d.index + 1}: {d.reason}" for d in rejected[:3])
            text += f"; {len(rejected)} rejected ({shown}{'; …' if len(rejected) > 3 else ''})"
        text += "." + note
        if self.result is not None and self.result_stale:
            text += " Pairs changed since the calibration: calibrate again."
        self._set_status(text, ok=None if not rejected else False)

    def _thumbnail_picked(self, key) -> None:
        """Show the picked pair in the rectified preview when it is part of the calibration."""
        if key is None or self.result is None or self.result_stale:
            return
        for a in self.items:
            if a.key == key and a.detection.index in self.result.view_indices:
                i = self.preview_combo.findData(a.detection.index)
                if i >= 0:
                    self.preview_combo.setCurrentIndex(i)
                return

    # -- calibration -----------------------------------------------------------------------------
    def calibrate(self) -> bool:
        if self._board_timer.isActive():
            self.apply_board()             # a board edit not applied yet
        if self.busy:
            self._set_status("Busy: wait for the running task or cancel it.", ok=False)
            return False
        usable = self.usable_pairs()
        if len(usable) < MIN_PAIRS_TO_CALIBRATE or self.detections is None:
            self._set_status(f"Calibration needs at least {MIN_PAIRS_TO_CALIBRATE} accepted pairs "
                             f"({len(usable)} now).", ok=False)
            return False
        self.detections = screen_pairs([a.detection for a in self.items], self._board)
        exclude = [a.detection.index for a in self.items if a.excluded]
        options = self.options()
        self._set_status(f"Calibrating from {len(self.usable_pairs())} pairs ({options.describe()})…")
        self._run_queue([(_part(calibrate_stereo, 0.0, 1.0, self.detections, options, exclude=exclude),
                          "Calibrating")], then=None)
        return True

    def _calibrated(self, result: StereoCalibrationResult) -> None:
        self.result = result
        self.result_stale = False
        self._show_result()
        self._refresh_pairs()
        cv = result.cross_validation
        text = (f"Calibrated: {result.pairs_used} pairs, stereo RMS {result.rms_stereo:.3f} px, epipolar "
                f"{result.epipolar_rms:.3f} px" + (f", cross-validation {cv.rms_observed_px:.3f} px" if cv else "")
                + f", baseline {result.baseline_mm:.2f} mm"
                + (f" ({len(result.warnings)} warning{'s' if len(result.warnings) > 1 else ''}: see Summary)"
                   if result.warnings else "")
                + ". Drop outliers if needed, then Save stereo.yaml.")
        self._set_status(text, ok=True)
        if self._autopilot_done is not None:
            QTimer.singleShot(0, self._autopilot_save)

    def _threshold_selection(self, rows: list) -> None:
        if self.result is None:
            return
        pairs = [self.result.view_indices[r] + 1 for r in rows]
        if pairs:
            self.outlier_label.setText(f"Above the line: pair{'s' if len(pairs) > 1 else ''} "
                                       f"{', '.join(map(str, pairs))} — Drop selected & recalibrate removes "
                                       f"{'them' if len(pairs) > 1 else 'it'}.")
        else:
            self.outlier_label.setText(self._outlier_text())
        self._update_buttons()

    def _outlier_text(self) -> str:
        r = self.result
        if r is None:
            return ""
        if r.outliers:
            parts = [f"pair {i + 1} ({r.per_view_rms[r.view_position(i)]:.3f} px)" for i in r.outliers]
            return (f"Flagged automatically (RMS above {r.outlier_threshold:.3f} px = median + "
                    f"{r.options.outlier_k:g}σ and ≥ {r.options.outlier_min_ratio:g}× median): {', '.join(parts)}. "
                    "Drag the line below them to drop them.")
        return (f"No pair flagged as an outlier (threshold {r.outlier_threshold:.3f} px). Drag the line down to "
                "drop pairs with the largest errors.")

    def selected_pairs(self) -> list[int]:
        """Pair indices (0-based) above the threshold line."""
        if self.result is None:
            return []
        return [self.result.view_indices[r] for r in self.errors_chart.selected()]

    def select_flagged(self) -> None:
        r = self.result
        if r is None or not r.outliers:
            return
        pos = [r.view_position(i) for i in r.outliers]
        lowest = min(max(r.per_view_rms_left[p], r.per_view_rms_right[p]) for p in pos)
        self.errors_chart.set_threshold(lowest * 0.98)

    def drop_selected(self) -> bool:
        r = self.result
        chosen = self.selected_pairs()
        if r is None or not chosen:
            self._set_status("Drag the threshold line below the bars of the pairs to drop.", ok=False)
            return False
        if self.busy:
            return False
        # by identity: pairs added or removed since the calibration renumber the others
        objects = {id(r.detections.pairs[i]) for i in chosen}
        for a in self.items:
            if id(a.detection) in objects:
                a.excluded = True
        self._changed()
        return self.calibrate()

    def restore_excluded(self) -> None:
        for a in self.items:
            a.excluded = False
        self._changed()
        self._report_pairs()

    # -- drawing the result ------------------------------------------------------------------------
    def _show_result(self) -> None:
        r = self.result
        if r is None:
            self.errors_chart.clear_errors()
            self.outlier_label.setText("Calibrate to see the reprojection error of every pair.")
            self.table.set_rows([])
            self.summary_view.setHtml("<p style='color:#5f6368'>No calibration yet. Add pairs until the coverage "
                                      "is enough, then Calibrate.</p>")
            self.preview_combo.blockSignals(True)
            self.preview_combo.clear()
            self.preview_combo.blockSignals(False)
            self.preview.set_image(None)
            for name in ("left_corners", "right_corners"):
                self.preview.set_points(name, None)
            self.preview.set_lines("epipolar", None)
            self.preview_caption.setText("")
            self.scatter.clear_residuals()
            self.scatter_caption.setText("")
            self.scatter_stats.setText("")
            self._update_buttons()
            return
        pairs = [i + 1 for i in r.view_indices]
        self.errors_chart.set_errors(pairs, r.per_view_rms_left, r.per_view_rms_right,
                                     flagged=[i in r.outliers for i in r.view_indices],
                                     auto_threshold=r.outlier_threshold)
        self.outlier_label.setText(self._outlier_text())
        self.table.set_rows(r.parameters)
        self.summary_view.setHtml(summary_html(r))
        self.scatter.set_residuals(r.residuals_left.reshape(-1, 2), r.residuals_right.reshape(-1, 2))
        n = r.residuals_left.shape[0] * r.residuals_left.shape[1]
        self.scatter_caption.setText(
            f"Observed − projected corner position, {n} corners per camera over {r.pairs_used} pairs. "
            "A round cloud centred on 0 is good; a pattern (a ring, a stripe, one direction) means the "
            "distortion model or some pairs are wrong. Circled: the pair shown in Rectified pair.")
        self.scatter_stats.setText(residual_stats_html(r))
        self.preview_combo.blockSignals(True)
        self.preview_combo.clear()
        for i, name in zip(r.view_indices, r.view_names):
            self.preview_combo.addItem(f"{i + 1}: {name}", i)
        self.preview_combo.blockSignals(False)
        self.preview_combo.setCurrentIndex(0)
        self._preview_changed()
        self._update_buttons()

    def _preview_changed(self, *_) -> None:
        r = self.result
        index = self.preview_combo.currentData()
        if r is None or index is None:
            return
        v = r.view_position(int(index))
        self.scatter.set_highlight(r.residuals_left[v], r.residuals_right[v], f"pair {int(index) + 1}")
        # the pairs as they were at the calibration (pairs added or removed since renumber the page's)
        pair = r.detections.pairs[int(index)] if r.detections is not None else None
        if pair is None:
            return
        rect = r.rectification
        self._preview_token += 1
        token = self._preview_token

        def shown(images):
            if token == self._preview_token and self.result is r:
                self._draw_preview(r, v, *images)

        def failed(message):
            if token == self._preview_token:
                self.preview.set_image(None)
                self.preview_caption.setText(message)

        self.preview_caption.setText("Rectifying this pair…")
        self.run_task(rect.rectify_files, pair.left_path, pair.right_path, on_result=shown, on_error=failed,
                      on_cancelled=lambda: None, label="Rectifying the preview")

    def _draw_preview(self, r, v: int, left_r: np.ndarray, right_r: np.ndarray) -> None:
        """The rectified pair side by side with the epipolar lines and the rectified corners."""
        rect = r.rectification
        h, w = left_r.shape[:2]
        gap = np.full((h, PREVIEW_GAP), 255, np.uint8)
        self.preview.set_image(np.concatenate([left_r, gap, right_r], axis=1))
        total_w = 2 * w + PREVIEW_GAP
        if rect.vertical:
            xs = np.arange(LINE_SPACING / 2, w, LINE_SPACING)
            segs = [[[x, 0], [x, h]] for x in xs] + [[[x + w + PREVIEW_GAP, 0], [x + w + PREVIEW_GAP, h]] for x in xs]
            self.preview.set_lines("epipolar", np.array(segs))
        else:
            self.preview.set_horizontal_lines("epipolar", np.arange(LINE_SPACING / 2, h, LINE_SPACING), 0, total_w)
        self.preview.set_points("left_corners", rect.rectified_left[v])
        self.preview.set_points("right_corners", rect.rectified_right[v] + np.array([w + PREVIEW_GAP, 0.0]))
        err = rect.epipolar_errors[v]
        self.preview_caption.setText(
            f"Rectified left | right. {'Vertical' if rect.vertical else 'Horizontal'} green lines every "
            f"{LINE_SPACING} px; red dots: the detected corners, rectified. Epipolar error of this pair: RMS "
            f"{float(np.sqrt(np.mean(err ** 2))):.3f} px, max {float(np.max(np.abs(err))):.3f} px.")

    # -- save and exports ---------------------------------------------------------------------------
    def save_stereo(self) -> Path | None:
        """Accept the calibration: stereo.yaml and its details (stereo.json) into the project
        (atomic) and the result into the wizard's state."""
        r, project = self.result, self.state.project
        if r is None or project is None:
            self._set_status("Nothing to save: calibrate first." if project is not None
                             else "No project: create or open one in the Setup step (1).", ok=False)
            return None
        path = project.path("stereo")
        try:
            write_stereo_yaml(path, r)
            write_stereo_json(project.path("stereo_details"), r)     # per-pair details for the report
        except RoboCalError as exc:
            self._set_status(f"stereo.yaml was not written: {exc.message}", ok=False)
            return None
        self.saved_path = path
        self.state.set_stereo(r)
        self._set_status(f"Saved {path} ({r.pairs_used} pairs, stereo RMS {r.rms_stereo:.3f} px). "
                         "This step is done.", ok=True)
        self.notify_complete()
        return path

    def export_ros(self, folder: str | None = None) -> tuple[Path, Path] | None:
        if self.result is None:
            return None
        if folder is None:
            start = str(self.state.project.folder) if self.state.project is not None else ""
            folder = QFileDialog.getExistingDirectory(self, "Folder for left.yaml and right.yaml (ROS camera_info)",
                                                      start)
            if not folder:
                return None
        try:
            paths = write_ros_camera_info(folder, self.result)
        except RoboCalError as exc:
            self._set_status(f"ROS camera_info not written: {exc.message}", ok=False)
            return None
        self._set_status(f"Wrote {paths[0]} and {paths[1].name} (ROS camera_info).", ok=True)
        return paths

    def export_json(self, path: str | None = None) -> Path | None:
        if self.result is None:
            return None
        if path is None:
            start = self.state.project.folder / "stereo.json" if self.state.project is not None else Path("stereo.json")
            path, _ = QFileDialog.getSaveFileName(self, "Export the stereo calibration as JSON", str(start),
                                                  "JSON (*.json)")
            if not path:
                return None
        try:
            out = write_stereo_json(path, self.result)
        except RoboCalError as exc:
            self._set_status(f"JSON not written: {exc.message}", ok=False)
            return None
        self._set_status(f"Wrote {out}.", ok=True)
        return Path(out)


# -- helpers ---------------------------------------------------------------------------------
@dataclass
class _Continue:
    """A worker result that continues on the GUI thread (e.g. queues more jobs)."""

    then: Callable[[], None]


def _then(fn: Callable, on_gui: Callable) -> Callable:
    """Run fn on the worker; hand its value to on_gui on the GUI thread before the next job."""
    def job(progress=None, cancelled=None):
        value = fn(progress=progress, cancelled=cancelled)
        return _Continue(lambda: on_gui(value))
    return job


def _sources(fn: Callable, sources: Sequence[str]) -> Callable:
    """Set each detected pair's source (where it first came from) after `fn`."""
    def job(progress=None, cancelled=None):
        out = fn(progress=progress, cancelled=cancelled)
        for a, s in zip(out, sources):
            a.source = s
        return out
    return job


_PAIR_NAME = re.compile(r"^pair_(\d+)\.png$")


def _next_free_number(folder: Path) -> int:
    """The first pair number after those already in folder/left and folder/right."""
    numbers = [-1]
    for side in ("left", "right"):
        d = folder / side
        if d.is_dir():
            for p in d.iterdir():
                m = _PAIR_NAME.match(p.name)
                if m:
                    numbers.append(int(m.group(1)))
    return max(numbers) + 1
