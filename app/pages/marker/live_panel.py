"""The Marker page's Live pair tab: both images of one stereo pair with every stage of the
detection drawn (SIFT matches, homography outline, region of interest, Canny edges, fitted
outline, reference point) and the located 3D point (mm, left camera frame) with its σ."""
from __future__ import annotations

import math

import numpy as np
from PySide6.QtCore import Qt
from PySide6.QtWidgets import QCheckBox, QHBoxLayout, QLabel, QVBoxLayout, QWidget

from app.html import esc
from app.jobs.marker import LiveResult
from app.pages.forms import button
from app.pages.measurement_inputs import StereoSource
from widgets.marker_views import CAPTION, MarkerImageView

IDLE_TEXT = ("<span style='color:#5f6368'>Next pose moves the robot to a random pose where both cameras see the "
             "marker and locates it.</span>")


def location_html(live: LiveResult, stereo: StereoSource) -> str:
    """The located 3D point with its σ (mm, left camera frame) and its error against the truth."""
    loc = live.location
    if not loc.ok:
        return f"<b style='color:#c5221f'>Not located</b> ({esc(loc.stage)} stage): {esc(loc.reason)}"
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
    """One line on each stage: SIFT matches, edge fit, SSD window, disparities, size, time."""
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
    return " · ".join(esc(p) for p in parts)


def draw_detection(view: MarkerImageView, det, missing: str = "") -> None:
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


class LivePanel(QWidget):
    """The Live pair tab; the page connects `next_button` and calls `draw(live, stereo)`."""

    def set_source(self, cameras: bool) -> None:
        """Capture from the cameras opened on the Setup page (True) or the virtual lab's."""
        if cameras:
            self.next_button.setText("Capture pair")
            self.next_button.setToolTip("Capture a pair from the two cameras, the robot where it is, and locate "
                                        "the marker")
        else:
            self.next_button.setText("Next pose")
            self.next_button.setToolTip("Move the (virtual) robot to a random pose where both cameras see the "
                                        "marker, capture a pair and locate the marker")

    def __init__(self, parent: QWidget | None = None):
        super().__init__(parent)
        self.next_button = button("Next pose", "nextPoseButton",
                                  tooltip="Move the (virtual) robot to a random pose where both cameras see the "
                                          "marker, capture a pair and locate the marker")
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
        layout = QVBoxLayout(self)
        layout.setContentsMargins(4, 4, 4, 4)
        layout.setSpacing(4)
        top = QHBoxLayout()
        top.addWidget(self.next_button)
        top.addWidget(self.zoom_check)
        top.addWidget(self.point_label, 1)
        layout.addLayout(top)
        views = QHBoxLayout()
        views.setSpacing(4)
        views.addWidget(self.left_view)
        views.addWidget(self.right_view)
        layout.addLayout(views, 1)
        layout.addWidget(self.caption)
        layout.addWidget(self.details_label)

    def draw(self, live: LiveResult | None, stereo: StereoSource) -> None:
        """Draw `live` (None: empty views and what Next pose does)."""
        if live is None:
            for view in (self.left_view, self.right_view):
                view.set_image(None)
                view.clear_detection()
            self.point_label.setText(IDLE_TEXT)
            self.details_label.setText("")
            return
        loc = live.location
        for view, det, image in ((self.left_view, loc.left, live.left), (self.right_view, loc.right, live.right)):
            view.set_image(image)
            draw_detection(view, det, "right image: not searched (the left one failed)" if det is None else "")
        self._zoom_toggled(self.zoom_check.isChecked())
        self.point_label.setText(location_html(live, stereo))
        self.details_label.setText(details_html(live))

    def _zoom_toggled(self, on: bool) -> None:
        for view in (self.left_view, self.right_view):
            if on:
                view.zoom_to(factor=2.4)
            else:
                view.reset_view()
