"""The table of compensated points: target, nominal and corrected joints, the predicted error of
the corrected landing and, after Go to point, where the marker landed and how it was measured."""
from __future__ import annotations

import numpy as np
from PySide6.QtWidgets import QAbstractItemView, QHeaderView, QTableWidget, QTableWidgetItem

COLUMNS = ["point", "target x, y, z (mm, camera frame)", "nominal joints (°)", "corrected joints (°)",
           "predicted error (mm)", "measured error, corrected (mm)", "measured error, nominal (mm)", "note"]


def _joints(q_file) -> str:
    q = np.asarray(q_file, dtype=float)
    return "unreachable" if not np.all(np.isfinite(q)) else "  ".join(f"{v:.2f}" for v in q)


class PointsTable(QTableWidget):
    def __init__(self, parent=None):
        super().__init__(0, len(COLUMNS), parent)
        self.setObjectName("compensatedPoints")
        self.setHorizontalHeaderLabels(COLUMNS)
        self.setSelectionBehavior(QAbstractItemView.SelectionBehavior.SelectRows)
        self.setSelectionMode(QAbstractItemView.SelectionMode.SingleSelection)
        self.setEditTriggers(QAbstractItemView.EditTrigger.NoEditTriggers)
        self.verticalHeader().setVisible(False)
        header = self.horizontalHeader()
        header.setSectionResizeMode(QHeaderView.ResizeMode.ResizeToContents)
        header.setStretchLastSection(True)

    def show_points(self, points, q_to_file, select: int | None = None) -> None:
        """One row per app.jobs.compensation.CompensatedPoint (joints through `q_to_file`: deg / mm);
        row `select` selected (None: the one selected, or the first)."""
        self.setRowCount(len(points))
        for r, p in enumerate(points):
            measured = ["" if not np.isfinite(p.error_mm(n)) else f"{p.error_mm(n):.3f}" for n in (False, True)]
            note = f"measured: {p.measured_by}" if p.measured_by and not p.note else p.note
            cells = [p.name, "  ".join(f"{v:.2f}" for v in p.target), _joints(q_to_file(p.q_nominal)),
                     _joints(q_to_file(p.q_corrected)),
                     "" if not np.isfinite(p.predicted_mm) else f"{p.predicted_mm:.3f}", *measured, note]
            for c, text in enumerate(cells):
                self.setItem(r, c, QTableWidgetItem(text))
        if points and self.currentRow() < 0:
            self.selectRow(0)
        if select is not None:
            self.selectRow(select)
