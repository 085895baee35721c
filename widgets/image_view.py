"""An image with overlays (lines, points), on pyqtgraph: the image is a row-major ImageItem
with fixed levels 0–255 (grey or RGB uint8), y down as in the image, aspect kept; overlay
items are created once (`add_points`, `add_lines`) and updated with `set_points` /
`set_lines`, never re-created. Pan and zoom with the mouse; double-click resets the view.
"""
from __future__ import annotations

import numpy as np
import pyqtgraph as pg
from PySide6.QtCore import Qt

from widgets.plot_theme import TEXT


class ImageView(pg.GraphicsLayoutWidget):
    def __init__(self, parent=None, *, axes: bool = False):
        super().__init__(parent=parent)
        self.setObjectName("imageView")
        self.setBackground("w")
        self.plot = self.addPlot(enableMenu=False)
        self.plot.hideButtons()
        self.plot.invertY(True)
        self.plot.setAspectLocked(True)
        if not axes:
            self.plot.hideAxis("left")
            self.plot.hideAxis("bottom")
        else:
            self.plot.setLabel("bottom", "x (px)", color=TEXT)
            self.plot.setLabel("left", "y (px)", color=TEXT)
        self.image_item = pg.ImageItem(axisOrder="row-major")
        self.image_item.setZValue(-10)
        self.plot.addItem(self.image_item)
        self.overlays: dict[str, pg.GraphicsObject] = {}
        self._shape: tuple[int, ...] = ()

    # -- image ----------------------------------------------------------------------------
    def set_image(self, image: np.ndarray | None, *, reset_view: bool = True) -> None:
        """Show a row-major (H, W) or (H, W, 3) uint8 image (levels fixed at 0–255)."""
        if image is None:
            self.image_item.clear()
            self._shape = ()
            return
        img = np.asarray(image)
        self.image_item.setImage(img, levels=(0, 255), autoLevels=False)
        if reset_view or img.shape[:2] != self._shape[:2]:
            self._shape = img.shape
            self.reset_view()
        self._shape = img.shape

    def image_shape(self) -> tuple[int, ...]:
        return self._shape

    def reset_view(self) -> None:
        if self._shape:
            h, w = self._shape[:2]
            self.plot.setRange(xRange=(0, w), yRange=(0, h), padding=0.01)

    def mouseDoubleClickEvent(self, event) -> None:
        self.reset_view()
        super().mouseDoubleClickEvent(event)

    # -- overlays -------------------------------------------------------------------------
    def add_points(self, name: str, *, colour: str = "#34a853", symbol: str = "+", size: float = 7,
                   width: float = 1.2) -> pg.ScatterPlotItem:
        item = pg.ScatterPlotItem(symbol=symbol, size=size, pen=pg.mkPen(colour, width=width),
                                  brush=pg.mkBrush(colour))
        return self._add(name, item)

    def add_lines(self, name: str, *, colour: str = "#34a853", width: float = 1.0,
                  style=Qt.PenStyle.SolidLine) -> pg.PlotCurveItem:
        item = pg.PlotCurveItem(pen=pg.mkPen(colour, width=width, style=style), connect="pairs")
        return self._add(name, item)

    def _add(self, name: str, item):
        if name in self.overlays:
            raise KeyError(f"overlay {name!r} exists")
        item.setZValue(10)
        self.plot.addItem(item)
        self.overlays[name] = item
        return item

    def set_points(self, name: str, xy) -> None:
        """Points (M, 2) in image px (x right, y down); empty or None hides them."""
        pts = np.zeros((0, 2)) if xy is None else np.asarray(xy, dtype=float).reshape(-1, 2)
        self.overlays[name].setData(pts[:, 0], pts[:, 1])

    def set_lines(self, name: str, segments) -> None:
        """Segments (M, 2, 2): [[x0, y0], [x1, y1]] each, in image px."""
        seg = np.zeros((0, 2, 2)) if segments is None else np.asarray(segments, dtype=float).reshape(-1, 2, 2)
        if len(seg) == 0:
            self.overlays[name].setData([], [])
            return
        xy = seg.reshape(-1, 2)
        self.overlays[name].setData(xy[:, 0], xy[:, 1], connect="pairs")

    def set_horizontal_lines(self, name: str, ys, x0: float, x1: float) -> None:
        ys = np.asarray(ys, dtype=float).reshape(-1)
        seg = np.stack([np.stack([np.full_like(ys, x0), ys], 1), np.stack([np.full_like(ys, x1), ys], 1)], 1)
        self.set_lines(name, seg)
