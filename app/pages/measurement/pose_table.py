"""The table of the poses to measure: pose, point (mm, left camera frame), σ, status."""
from __future__ import annotations

import numpy as np
from PySide6.QtCore import Qt
from PySide6.QtGui import QBrush, QColor
from PySide6.QtWidgets import QAbstractItemView, QHeaderView, QTableWidget, QTableWidgetItem

from app.jobs.measurement import MEASURED, PENDING, REJECTED, RUNNING, PoseRow
from app.pages.measurement.texts import short

STATUS_COLUMN = 5
STATUS_COLOURS = {MEASURED: "#188038", REJECTED: "#c5221f", PENDING: "#5f6368", RUNNING: "#1a73e8"}


class PoseTable(QTableWidget):
    """One row per pose; the status coloured, a rejection's full reason in its tooltip. After
    `follow(model)` it shows a MeasurementModel's rows as they change."""

    def __init__(self, parent=None):
        super().__init__(0, 6, parent)
        self.setObjectName("poseTable")
        self.setHorizontalHeaderLabels(["Pose", "x (mm)", "y (mm)", "z (mm)", "σ (mm)", "Status"])
        self.setEditTriggers(QAbstractItemView.EditTrigger.NoEditTriggers)
        self.setSelectionBehavior(QAbstractItemView.SelectionBehavior.SelectRows)
        self.setSelectionMode(QAbstractItemView.SelectionMode.SingleSelection)
        self.verticalHeader().setVisible(False)
        header = self.horizontalHeader()
        header.setSectionResizeMode(QHeaderView.ResizeMode.ResizeToContents)
        header.setSectionResizeMode(STATUS_COLUMN, QHeaderView.ResizeMode.Stretch)
        self.setMinimumWidth(400)

    def follow(self, model) -> None:
        """Every row anew ("rows"), a pose being measured ("row"), a pose done ("pose": selected,
        which scrolls to it)."""
        model.on("rows", self.set_rows)
        model.on("row", lambda i: self.set_row(i, model.rows[i]))
        model.on("pose", self._pose_done)

    def _pose_done(self, shown) -> None:
        self.set_row(shown.index, shown.row)
        self.selectRow(shown.index)

    def set_rows(self, rows: list[PoseRow]) -> None:
        """Show every row (no selection signal while filling)."""
        self.blockSignals(True)
        self.setRowCount(len(rows))
        for i, r in enumerate(rows):
            self.set_row(i, r)
        self.blockSignals(False)

    def set_row(self, i: int, r: PoseRow) -> None:
        status = {MEASURED: "✓ measured", PENDING: "pending", RUNNING: "▶ measuring…",
                  REJECTED: f"✗ rejected: {short(r.reason)}"}[r.status]
        cells = [str(r.pose)]
        if r.point is not None:
            cells += [f"{v:.2f}" for v in r.point]
            cells.append(f"{float(np.linalg.norm(r.sigma)):.3f}" if r.sigma is not None else "–")
        else:
            cells += ["", "", "", ""]
        cells.append(status)
        colour = QBrush(QColor(STATUS_COLOURS[r.status]))
        for j, text in enumerate(cells):
            item = self.item(i, j)
            if item is None:
                item = QTableWidgetItem()
                self.setItem(i, j, item)
            item.setText(text)
            if j == STATUS_COLUMN:
                item.setForeground(colour)
                item.setToolTip(r.reason if r.status == REJECTED else "")
            else:
                item.setTextAlignment(Qt.AlignmentFlag.AlignRight | Qt.AlignmentFlag.AlignVCenter)

    def selected(self) -> int | None:
        """The selected row, or None."""
        rows = self.selectionModel().selectedRows() if self.selectionModel() else []
        return rows[0].row() if rows else None
