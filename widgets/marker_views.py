"""Images of the marker with what each stage of its detection found, on pyqtgraph.

`MarkerImageView` (an `ImageView`) draws, in image pixels:
- SIFT: the scene keypoints (faint dots), the matches that agree with the homography
  (inliers, green circles) and those that do not (red crosses), the outline the homography
  predicts (dashed yellow) and the training reference point mapped through it (yellow x);
- the region of interest (dashed blue rectangle) where Canny runs;
- Canny: the edge pixels used for the four sides (cyan) and the others (grey);
- the fitted outline (green polyline along the four fitted sides) and the reference point,
  the intersection of its diagonals (red crosshair with the diagonals).
`show_detection(...)` takes plain arrays (None hides a layer); `zoom_to(box)` frames a region.

`TrainingImageView` adds a crop rectangle (pg.RectROI) for the training image.
"""
from __future__ import annotations

import numpy as np
import pyqtgraph as pg
from PySide6.QtCore import QPointF, Qt, Signal

from widgets.image_view import ImageView

INLIER = "#34a853"
OUTLIER = "#d93025"
KEYPOINT = "#9aa0a6"
SIFT = "#f9ab00"
ROI = "#1a73e8"
EDGE = "#00bcd4"
EDGE_OTHER = "#bdc1c6"
FITTED = "#0f9d58"
REFERENCE = "#d93025"
AUTO_OUTLINE = "#e37400"

CAPTION = (f"<span style='color:{INLIER}'>○</span> SIFT matches that agree "
           f"<span style='color:{OUTLIER}'>✕</span> that do not &nbsp; "
           f"<span style='color:{SIFT}'>┅</span> homography outline "
           f"<span style='color:{SIFT}'>✕</span> its centre &nbsp; "
           f"<span style='color:{ROI}'>┅</span> region of interest &nbsp; "
           f"<span style='color:{EDGE}'>●</span> Canny edge pixels &nbsp; "
           f"<span style='color:{FITTED}'>━</span> fitted outline &nbsp; "
           f"<span style='color:{REFERENCE}'>✛</span> reference point")


def _closed(poly) -> np.ndarray | None:
    """Segments (M, 2, 2) of a closed polygon (K, 2)."""
    if poly is None:
        return None
    p = np.asarray(poly, dtype=float).reshape(-1, 2)
    if len(p) < 2:
        return None
    return np.stack([p, np.roll(p, -1, axis=0)], axis=1)


def _box(box) -> np.ndarray | None:
    if box is None:
        return None
    x0, y0, x1, y1 = (float(v) for v in box)
    if x1 <= x0 or y1 <= y0:
        return None
    return _closed([[x0 - 0.5, y0 - 0.5], [x1 - 0.5, y0 - 0.5], [x1 - 0.5, y1 - 0.5], [x0 - 0.5, y1 - 0.5]])


def crosshair(point, size: float, corners=None) -> np.ndarray | None:
    """Segments of a crosshair of half-size `size` at `point`, plus the diagonals of `corners`."""
    if point is None:
        return None
    x, y = (float(v) for v in np.asarray(point, dtype=float).reshape(2))
    seg = [[[x - size, y], [x + size, y]], [[x, y - size], [x, y + size]]]
    if corners is not None:
        c = np.asarray(corners, dtype=float).reshape(4, 2)
        seg += [[c[0], c[2]], [c[1], c[3]]]
    return np.asarray(seg, dtype=float)


class MarkerImageView(ImageView):
    """An image with the layers of the marker detection (see the module docstring)."""

    def __init__(self, parent=None, *, title: str = ""):
        super().__init__(parent)
        if title:
            self.plot.setTitle(title, color="#202124", size="9pt")
        self.add_points("keypoints", colour=KEYPOINT, symbol="o", size=2.5, width=0)
        self.overlays["keypoints"].setPen(None)
        self.add_points("outliers", colour=OUTLIER, symbol="x", size=6, width=1.0)
        inl = self.add_points("inliers", colour=INLIER, symbol="o", size=7, width=1.3)
        inl.setBrush(None)
        self.add_lines("roi", colour=ROI, width=1.2, style=Qt.PenStyle.DashLine)
        self.add_points("edges_other", colour=EDGE_OTHER, symbol="s", size=2, width=0)
        self.overlays["edges_other"].setPen(None)
        self.add_points("edges", colour=EDGE, symbol="s", size=2.5, width=0)
        self.overlays["edges"].setPen(None)
        self.add_lines("sift_outline", colour=SIFT, width=1.5, style=Qt.PenStyle.DashLine)
        self.add_points("sift_reference", colour=SIFT, symbol="x", size=11, width=1.5)
        self.add_lines("fitted", colour=FITTED, width=1.6)
        self.add_lines("reference", colour=REFERENCE, width=1.4)
        self.add_points("reference_dot", colour=REFERENCE, symbol="o", size=5, width=1)
        self.message = pg.TextItem("", color="#c5221f", anchor=(0, 0))
        self.message.setZValue(20)
        self.plot.addItem(self.message)
        self._marker_box: tuple[float, float, float, float] | None = None

    def show_detection(self, *, keypoints=None, inliers=None, outliers=None, sift_outline=None, sift_reference=None,
                       roi=None, edges=None, edges_other=None, fitted=None, reference=None, corners=None,
                       message: str = "") -> None:
        """Draw the layers given (image px); the others are hidden."""
        self.set_points("keypoints", keypoints)
        self.set_points("inliers", inliers)
        self.set_points("outliers", outliers)
        self.set_lines("sift_outline", _closed(sift_outline))
        self.set_points("sift_reference", None if sift_reference is None else np.reshape(sift_reference, (1, 2)))
        self.set_lines("roi", _box(roi))
        self.set_points("edges", edges)
        self.set_points("edges_other", edges_other)
        self.set_lines("fitted", _closed(fitted))
        size = 10.0
        box = None
        for quad in (fitted, sift_outline):
            if quad is not None and len(quad):
                q = np.asarray(quad, dtype=float).reshape(-1, 2)
                size = 0.35 * float(max(np.ptp(q[:, 0]), np.ptp(q[:, 1]), 8.0))
                box = (q[:, 0].min(), q[:, 1].min(), q[:, 0].max(), q[:, 1].max())
                break
        if box is None and roi is not None:
            box = tuple(float(v) for v in roi)
        self._marker_box = box
        self.set_lines("reference", crosshair(reference, size, corners))
        self.set_points("reference_dot", None if reference is None else np.reshape(reference, (1, 2)))
        self.set_message(message)

    def clear_detection(self) -> None:
        self.show_detection()

    def set_message(self, text: str) -> None:
        """A short note drawn in the top-left corner of the image (e.g. why nothing was found)."""
        self.message.setText(text or "")
        self.message.setPos(8, 8)


    def zoom_to(self, box=None, factor: float = 2.2) -> None:
        """Frame `box` (x0, y0, x1, y1; default the marker) enlarged by `factor`, or the whole image."""
        box = self._marker_box if box is None else box
        if box is None or not self._shape:
            self.reset_view()
            return
        x0, y0, x1, y1 = (float(v) for v in box)
        cx, cy = 0.5 * (x0 + x1), 0.5 * (y0 + y1)
        half = 0.5 * factor * max(x1 - x0, y1 - y0, 20.0)
        self.plot.setRange(xRange=(cx - half, cx + half), yRange=(cy - half, cy + half), padding=0)


class TrainingImageView(MarkerImageView):
    """The training image with the automatically found outline, the trained outline,
    keypoints and reference point, and an optional crop rectangle.

    Signal `cropChanged(object)`: the new crop box (x0, y0, x1, y1) after a drag."""

    cropChanged = Signal(object)

    def __init__(self, parent=None):
        super().__init__(parent)
        self.add_lines("auto_outline", colour=AUTO_OUTLINE, width=2.0, style=Qt.PenStyle.DashLine)
        self.crop_roi = pg.RectROI([0, 0], [100, 100], pen=pg.mkPen(ROI, width=2),
                                   hoverPen=pg.mkPen("#174ea6", width=2.5), removable=False)
        self.crop_roi.addScaleHandle([0, 0], [1, 1])
        self.crop_roi.addScaleHandle([1, 0], [0, 1])
        self.crop_roi.addScaleHandle([0, 1], [1, 0])
        self.crop_roi.setZValue(30)
        self.crop_roi.hide()
        self.plot.addItem(self.crop_roi)
        self.crop_roi.sigRegionChangeFinished.connect(lambda *_: self.cropChanged.emit(self.crop_box()))

    def set_auto_outline(self, outline) -> None:
        self.set_lines("auto_outline", _closed(outline))

    def set_crop_visible(self, visible: bool) -> None:
        self.crop_roi.setVisible(bool(visible))

    @property
    def crop_visible(self) -> bool:
        return self.crop_roi.isVisible()

    def set_crop_box(self, box) -> None:
        """Place the crop rectangle on (x0, y0, x1, y1) image px (x1, y1 exclusive)."""
        x0, y0, x1, y1 = (float(v) for v in box)
        self.crop_roi.setPos(QPointF(x0, y0), update=False, finish=False)
        self.crop_roi.setSize(QPointF(x1 - x0, y1 - y0), update=True, finish=False)

    def crop_box(self) -> tuple[int, int, int, int] | None:
        """The crop rectangle as whole pixels (x0, y0, x1, y1) inside the image, or None."""
        if not self._shape:
            return None
        h, w = self._shape[:2]
        pos, size = self.crop_roi.pos(), self.crop_roi.size()
        x0 = int(np.clip(round(pos.x()), 0, w - 1))
        y0 = int(np.clip(round(pos.y()), 0, h - 1))
        x1 = int(np.clip(round(pos.x() + size.x()), x0 + 1, w))
        y1 = int(np.clip(round(pos.y() + size.y()), y0 + 1, h))
        return x0, y0, x1, y1
