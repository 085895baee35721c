"""A read-only table of a robot's DH parameters, in the units of files and screens."""
from __future__ import annotations

import numpy as np
from PySide6.QtCore import QSize, Qt
from PySide6.QtWidgets import (QAbstractItemView, QHeaderView, QSizePolicy, QTableWidget,
                               QTableWidgetItem, QWidget)

from core.robot.model import RobotModel

COLUMNS = ["Joint", "Type", "θ offset (°)", "d (mm)", "a (mm)", "α (°)", "β (°)", "min", "max"]


def _fmt(value: float, decimals: int = 3) -> str:
    text = f"{round(float(value), decimals):.{decimals}f}".rstrip("0").rstrip(".")
    return "0" if text in ("-0", "") else text


class DHTable(QTableWidget):
    """`set_robot(model)` fills one row per joint; `set_robot(None)` empties it.
    Joint limits are in ° for revolute joints and mm for prismatic ones."""

    def __init__(self, parent: QWidget | None = None):
        super().__init__(0, len(COLUMNS), parent)
        self.setObjectName("dhTable")
        self.setHorizontalHeaderLabels(COLUMNS)
        self.setEditTriggers(QAbstractItemView.EditTrigger.NoEditTriggers)
        self.setSelectionBehavior(QAbstractItemView.SelectionBehavior.SelectRows)
        self.setAlternatingRowColors(True)
        self.verticalHeader().setVisible(False)
        header = self.horizontalHeader()
        header.setSectionResizeMode(QHeaderView.ResizeMode.Stretch)
        for name in ("Joint", "Type", "θ offset (°)"):     # names (shoulder_lift_joint …) never cut
            header.setSectionResizeMode(COLUMNS.index(name), QHeaderView.ResizeMode.ResizeToContents)
        header.setDefaultAlignment(Qt.AlignmentFlag.AlignCenter)
        # as tall as its rows (at least `min_rows`), no taller: no empty grid below the robot
        self.min_rows = 6
        self.setSizePolicy(QSizePolicy.Policy.Expanding, QSizePolicy.Policy.Maximum)

    def sizeHint(self) -> QSize:
        hint = super().sizeHint()
        rows = max(self.rowCount(), self.min_rows)
        height = (self.horizontalHeader().sizeHint().height()
                  + rows * self.verticalHeader().defaultSectionSize() + 2 * self.frameWidth() + 6)
        return QSize(hint.width(), height)

    def minimumSizeHint(self) -> QSize:
        return QSize(super().minimumSizeHint().width(), self.horizontalHeader().sizeHint().height()
                     + 3 * self.verticalHeader().defaultSectionSize())

    def set_robot(self, model: RobotModel | None) -> None:
        self.setRowCount(0)
        if model is None:
            return
        self.setRowCount(model.dof)
        for row, joint in enumerate(model.joints):
            rev = joint.revolute
            unit = "°" if rev else " mm"
            lim = np.rad2deg if rev else (lambda v: v)
            cells = [joint.name or f"J{row + 1}", joint.type,
                     _fmt(np.rad2deg(joint.theta)), _fmt(joint.d), _fmt(joint.a),
                     _fmt(np.rad2deg(joint.alpha)), _fmt(np.rad2deg(joint.beta)),
                     _fmt(lim(joint.min)) + unit, _fmt(lim(joint.max)) + unit]
            for col, text in enumerate(cells):
                item = QTableWidgetItem(text)
                align = Qt.AlignmentFlag.AlignLeft if col < 2 else Qt.AlignmentFlag.AlignRight
                item.setTextAlignment(align | Qt.AlignmentFlag.AlignVCenter)
                self.setItem(row, col, item)
        self.updateGeometry()

    def cell_text(self, row: int, col: int) -> str:
        item = self.item(row, col)
        return item.text() if item is not None else ""
