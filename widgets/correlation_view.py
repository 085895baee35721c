"""A correlation matrix as an image: diverging colours from −1 (blue) through 0 (white) to
+1 (red), a colour bar, the parameter names on the axes, and the pair under the mouse named
in a line below the image (and in its tool tip)."""
from __future__ import annotations

from typing import Sequence

import numpy as np
import pyqtgraph as pg
from PySide6.QtCore import QPointF, Signal
from PySide6.QtGui import QFont
from PySide6.QtWidgets import QLabel, QVBoxLayout, QWidget

from widgets.plot_theme import AXIS, TEXT

COLORMAP = "CET-D1"          # blue – white – red, perceptually uniform
STRONG = 0.9                 # |correlation| above this is worth a look


class CorrelationView(QWidget):
    """`set_matrix(matrix, names)`; `hover_text(row, col)`; signal `hovered(str)`."""

    hovered = Signal(str)

    def __init__(self, parent=None):
        super().__init__(parent)
        self.graphics = pg.GraphicsLayoutWidget()
        self.graphics.setBackground("w")
        self.plot = self.graphics.addPlot(enableMenu=False)
        self.plot.hideButtons()
        self.plot.setMouseEnabled(x=False, y=False)
        self.plot.invertY(True)
        self.plot.setAspectLocked(True)
        font = QFont()
        font.setPointSizeF(7.5)
        for name in ("left", "bottom"):
            axis = self.plot.getAxis(name)
            axis.setPen(pg.mkPen(AXIS))
            axis.setTextPen(pg.mkPen(TEXT))
            axis.setTickFont(font)
        self.plot.setLabel("bottom", "parameter (number)", color=TEXT, size="9pt")
        self.image = pg.ImageItem(axisOrder="row-major")
        self.image.setLevels((-1.0, 1.0))
        self.plot.addItem(self.image)
        self.colormap = pg.colormap.get(COLORMAP)
        self.colorbar = pg.ColorBarItem(values=(-1.0, 1.0), colorMap=self.colormap, interactive=False,
                                        width=16)
        self.colorbar.setImageItem(self.image, insert_in=self.plot)
        cbar_axis = self.colorbar.getAxis("right")
        cbar_axis.setPen(pg.mkPen(AXIS))
        cbar_axis.setTextPen(pg.mkPen(TEXT))
        self.colorbar.getAxis("right").setLabel("correlation", color=TEXT)
        self.info = QLabel("Move the mouse over the matrix to read a pair of parameters.")
        self.info.setObjectName("hint")
        self.info.setWordWrap(True)
        layout = QVBoxLayout(self)
        layout.setContentsMargins(0, 0, 0, 0)
        layout.addWidget(self.graphics, 1)
        layout.addWidget(self.info)
        self.matrix = np.zeros((0, 0))
        self.names: list[str] = []
        self.graphics.scene().sigMouseMoved.connect(self._mouse_moved)

    def set_matrix(self, matrix, names: Sequence[str]) -> None:
        m = np.asarray(matrix, dtype=float)
        names = [str(n) for n in names]
        if m.ndim != 2 or m.shape[0] != m.shape[1] or m.shape[0] != len(names):
            raise ValueError("a square matrix with one name per row is expected")
        self.matrix = np.clip(np.where(np.isfinite(m), m, 0.0), -1.0, 1.0)
        self.names = names
        p = len(names)
        if p == 0:
            self.image.clear()
            return
        self.image.setImage(self.matrix, levels=(-1.0, 1.0), autoLevels=False)
        self.image.setRect(0, 0, p, p)
        left = [(i + 0.5, f"{name}  {i + 1}") for i, name in enumerate(names)]
        step = 1 if p <= 30 else int(np.ceil(p / 30))
        bottom_step = 1 if p <= 15 else (2 if p <= 40 else 5)
        bottom = [(i + 0.5, str(i + 1)) for i in range(0, p, bottom_step)]
        self.plot.getAxis("left").setTicks([left[::step], []])
        self.plot.getAxis("bottom").setTicks([bottom, []])
        self.plot.setRange(xRange=(0, p), yRange=(0, p), padding=0.01)
        strong = self.strong_pairs()
        if strong:
            shown = ", ".join(f"{a}–{b} {v:+.2f}" for a, b, v in strong[:4])
            more = f" and {len(strong) - 4} more" if len(strong) > 4 else ""
            self.info.setText(f"Strongly correlated (|r| > {STRONG}): {shown}{more}. "
                              "Move the mouse over the matrix to read any pair.")
        else:
            self.info.setText(f"No pair is correlated beyond |r| = {STRONG}. "
                              "Move the mouse over the matrix to read any pair.")

    def clear(self) -> None:
        self.matrix = np.zeros((0, 0))
        self.names = []
        self.image.clear()
        self.plot.getAxis("left").setTicks(None)
        self.plot.getAxis("bottom").setTicks(None)
        self.info.setText("")

    def strong_pairs(self, threshold: float = STRONG) -> list[tuple[str, str, float]]:
        """(name, name, r) of the off-diagonal pairs with |r| > threshold, strongest first."""
        p = len(self.names)
        out = [(self.names[i], self.names[j], float(self.matrix[i, j]))
               for i in range(p) for j in range(i + 1, p) if abs(self.matrix[i, j]) > threshold]
        return sorted(out, key=lambda t: -abs(t[2]))

    def hover_text(self, row: int, col: int) -> str:
        if not (0 <= row < len(self.names) and 0 <= col < len(self.names)):
            return ""
        return (f"{self.names[row]} ({row + 1}) × {self.names[col]} ({col + 1}): "
                f"correlation {self.matrix[row, col]:+.3f}")

    def _mouse_moved(self, pos: QPointF) -> None:
        if not len(self.names) or not self.plot.sceneBoundingRect().contains(pos):
            return
        point = self.plot.vb.mapSceneToView(pos)
        col, row = int(np.floor(point.x())), int(np.floor(point.y()))
        text = self.hover_text(row, col)
        if text:
            self.info.setText(text)
            self.graphics.setToolTip(text)
            self.hovered.emit(text)
