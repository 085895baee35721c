"""A planar checkerboard: inner-corner grid and square size (mm).

Board frame: origin at the first inner corner, x along a row (cols), y along a column
(rows), z = 0 on the board plane (z points into the board, away from a camera facing it).
Corner order is row-major, as OpenCV returns it for a (cols, rows) pattern.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from core.errors import UsageError


@dataclass(frozen=True)
class Board:
    cols: int = 9          # inner corners per row
    rows: int = 6          # inner corners per column
    square: float = 24.0   # mm

    @property
    def pattern_size(self) -> tuple[int, int]:
        """(cols, rows) as OpenCV's pattern size."""
        return (self.cols, self.rows)

    @property
    def corner_count(self) -> int:
        return self.cols * self.rows

    def object_points(self) -> np.ndarray:
        """(cols·rows, 3) corner positions in the board frame, mm, float32 (for OpenCV)."""
        xs, ys = np.meshgrid(np.arange(self.cols), np.arange(self.rows))
        pts = np.stack([xs.ravel(), ys.ravel(), np.zeros(xs.size)], axis=1) * self.square
        return pts.astype(np.float32)

    @classmethod
    def parse(cls, size_text: str, square: float) -> "Board":
        """From '9x6' and a square size in mm (command-line style)."""
        try:
            cols, rows = (int(v) for v in size_text.lower().split("x"))
        except ValueError as exc:
            raise UsageError(f"board size must look like 9x6 (inner corners), got '{size_text}'") from exc
        if cols < 2 or rows < 2:
            raise UsageError(f"board needs at least 2x2 inner corners, got '{size_text}'")
        if not square > 0:
            raise UsageError(f"square size must be positive (mm), got {square}")
        return cls(cols, rows, float(square))

    def to_dict(self) -> dict:
        return {"cols": self.cols, "rows": self.rows, "square": self.square}
