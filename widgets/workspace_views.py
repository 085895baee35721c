"""Two orthographic views of the workspace in the left camera frame (no OpenGL, so offscreen
tests can draw them): top (x horizontal, z = depth upwards) and side (z = depth horizontal,
y downwards, as in the camera frame, so that up on the screen is up in the room).

Each view shows the cameras as triangles with their field-of-view wedges (up to `depth`
mm), candidate marker positions as faint dots, the selected marker positions as dots, and the
arm of the highlighted pose as a polyline with its joints, the highlighted marker in red.
Data come as 3D points (mm, left camera frame); `camera_wedges` computes the wedges from a
stereo rig (core.stereo.rig.StereoRig).
"""
from __future__ import annotations

import numpy as np
import pyqtgraph as pg
from PySide6.QtCore import QPointF, Qt
from PySide6.QtGui import QPolygonF
from PySide6.QtWidgets import QGraphicsPolygonItem, QGridLayout, QLabel, QWidget

from widgets.plot_theme import AFTER, colour, style_plot

CAMERA = "#5f6368"
ARM = "#202124"
HIGHLIGHT = "#d93025"
CANDIDATE = "#9aa0a6"
AXES = {"x": 0, "y": 1, "z": 2}
CAPTION = (f"<span style='color:{AFTER}'>●</span> selected markers &nbsp; "
           f"<span style='color:{CANDIDATE}'>●</span> candidates &nbsp; "
           f"<span style='color:{ARM}'>━●━</span> arm in the highlighted pose, "
           f"<span style='color:{HIGHLIGHT}'>●</span> its marker &nbsp; "
           f"<span style='color:{CAMERA}'>▲</span> cameras and field of view")


def camera_wedges(rig, depth: float = 1000.0) -> list[dict]:
    """For each camera of a StereoRig: its name, optical centre and the 3D corners of the
    horizontal (top view) and vertical (side view) field-of-view wedges, in the left frame."""
    out = []
    for name, cam, R_to_left, centre in (("left", rig.left, np.eye(3), np.zeros(3)),
                                         ("right", rig.right, np.asarray(rig.R).T, rig.right_centre)):
        cx, cy = cam.K[0, 2], cam.K[1, 2]
        edges = {"top": np.array([[-0.5, cy], [cam.width - 0.5, cy]]),
                 "side": np.array([[cx, -0.5], [cx, cam.height - 0.5]])}
        wedge = {}
        for view, px in edges.items():
            xy = cam.pixels_to_normalized(px)
            rays = np.column_stack([xy, np.ones(len(xy))]) @ R_to_left.T
            ends = centre + rays / rays[:, 2:3] * depth      # up to `depth` along the optical axis
            wedge[view] = np.vstack([centre, ends])
        out.append({"name": name, "centre": np.asarray(centre, dtype=float), "top": wedge["top"],
                    "side": wedge["side"], "axis": R_to_left @ np.array([0.0, 0.0, 1.0])})
    return out


class OrthoView(pg.PlotWidget):
    """One orthographic view: `h`, `v` name the world axes drawn horizontally and vertically."""

    def __init__(self, h: str, v: str, title: str, *, invert_v: bool = False, wedge_key: str = "top",
                 parent=None):
        super().__init__(parent=parent, background="w", enableMenu=False)
        self.h, self.v = AXES[h], AXES[v]
        self.wedge_key = wedge_key
        self.plot_item = self.getPlotItem()
        style_plot(self.plot_item, f"{h} (mm)", f"{v} (mm{', down' if invert_v else ''})", title)
        self.plot_item.setAspectLocked(True)
        if invert_v:
            self.plot_item.invertY(True)
        self._wedges: list[QGraphicsPolygonItem] = []
        self.cameras = pg.ScatterPlotItem(symbol="t1" if not invert_v else "t", size=13, brush=colour(CAMERA),
                                          pen=pg.mkPen("w"))
        self.candidates = pg.ScatterPlotItem(size=3, brush=colour(CANDIDATE, 110), pen=None)
        self.selected = pg.ScatterPlotItem(size=7, brush=colour(AFTER, 220), pen=pg.mkPen("w", width=0.8))
        self.arm = pg.PlotDataItem(pen=pg.mkPen(ARM, width=3), symbol="o", symbolSize=6, symbolBrush=colour(ARM),
                                   symbolPen=pg.mkPen("w"))
        self.highlight = pg.ScatterPlotItem(size=13, brush=colour(HIGHLIGHT), pen=pg.mkPen("w", width=1.2))
        for item in (self.candidates, self.cameras, self.selected, self.arm, self.highlight):
            self.addItem(item)

    def _xy(self, P) -> tuple[np.ndarray, np.ndarray]:
        P = np.asarray(P, dtype=float).reshape(-1, 3)
        return P[:, self.h], P[:, self.v]

    def set_cameras(self, wedges: list[dict]) -> None:
        for item in self._wedges:
            self.plot_item.vb.removeItem(item)
        self._wedges.clear()
        centres = []
        for w in wedges:
            x, y = self._xy(w[self.wedge_key])
            poly = QGraphicsPolygonItem(QPolygonF([QPointF(float(a), float(b)) for a, b in zip(x, y)]))
            poly.setBrush(pg.mkBrush(colour(CAMERA, 28)))
            poly.setPen(pg.mkPen(colour(CAMERA, 150), width=1, style=Qt.PenStyle.DashLine))
            poly.setZValue(-10)
            self.plot_item.vb.addItem(poly)
            self._wedges.append(poly)
            centres.append(w["centre"])
        if centres:
            self.cameras.setData(*self._xy(np.array(centres)))
        else:
            self.cameras.setData([], [])

    def set_candidates(self, points) -> None:
        self.candidates.setData(*self._xy(points))

    def set_selected(self, points) -> None:
        self.selected.setData(*self._xy(points))

    def set_arm(self, points, marker=None) -> None:
        if points is None or len(points) == 0:
            self.arm.setData([], [])
            self.highlight.setData([], [])
            return
        self.arm.setData(*self._xy(points))
        self.highlight.setData(*self._xy(marker if marker is not None else np.asarray(points)[-1:]))

    def fit(self, points) -> None:
        """Show all the given points (mm, left frame) with a margin."""
        P = np.asarray(points, dtype=float).reshape(-1, 3)
        P = P[np.all(np.isfinite(P), axis=1)]
        if not len(P):
            return
        x, y = self._xy(P)
        pad_x = 0.08 * max(float(np.ptp(x)), 100.0)
        pad_y = 0.08 * max(float(np.ptp(y)), 100.0)
        self.plot_item.setRange(xRange=(float(x.min()) - pad_x, float(x.max()) + pad_x),
                                yRange=(float(y.min()) - pad_y, float(y.max()) + pad_y), padding=0)

    def clear_scene(self) -> None:
        self.set_cameras([])
        for item in (self.candidates, self.selected, self.highlight):
            item.setData([], [])
        self.arm.setData([], [])


class WorkspaceViews(QWidget):
    """The top (x–z) and side (z–y) views side by side, fed together."""

    def __init__(self, parent=None, *, title_top: str = "Top view (x–z, left camera frame)",
                 title_side: str = "Side view (z–y, left camera frame)"):
        super().__init__(parent)
        self.top = OrthoView("x", "z", title_top, wedge_key="top")
        self.side = OrthoView("z", "y", title_side, invert_v=True, wedge_key="side")
        self.top.setObjectName("topView")
        self.side.setObjectName("sideView")
        self.caption = QLabel(CAPTION)
        self.caption.setObjectName("hint")
        self.caption.setWordWrap(True)
        layout = QGridLayout(self)
        layout.setContentsMargins(0, 0, 0, 0)
        layout.setHorizontalSpacing(6)
        layout.setVerticalSpacing(2)
        layout.addWidget(self.top, 0, 0)
        layout.addWidget(self.side, 0, 1)
        layout.addWidget(self.caption, 1, 0, 1, 2)
        layout.setRowStretch(0, 1)
        self._extent = np.zeros((0, 3))

    @property
    def views(self) -> tuple[OrthoView, OrthoView]:
        return self.top, self.side

    def set_scene(self, *, wedges=None, candidates=None, selected=None, arm=None, marker=None,
                  extent=None) -> None:
        """Draw a new scene (None leaves that layer empty) and fit both views to it and to the
        `extent` points (e.g. the arm in every selected pose)."""
        for view in self.views:
            view.set_cameras(wedges or [])
            view.set_candidates(np.zeros((0, 3)) if candidates is None else candidates)
            view.set_selected(np.zeros((0, 3)) if selected is None else selected)
            view.set_arm(arm, marker)
        parts = [np.asarray(part, dtype=float).reshape(-1, 3) for part in (selected, arm, candidates, extent)
                 if part is not None and len(part)]
        parts += [np.asarray(w["centre"], dtype=float)[None, :] for w in wedges or []]
        self._extent = np.vstack(parts) if parts else np.zeros((0, 3))
        for view in self.views:
            view.fit(self._extent)

    def set_highlight(self, arm, marker=None) -> None:
        for view in self.views:
            view.set_arm(arm, marker)

    def clear_scene(self) -> None:
        for view in self.views:
            view.clear_scene()

