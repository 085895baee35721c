"""The Pose sequence page's results: the index versus N beside random selections, the comparison
in numbers, the selected poses on two orthographic views of the workspace and as a table."""
from __future__ import annotations

import numpy as np
from PySide6.QtCore import Qt
from PySide6.QtWidgets import (QAbstractItemView, QHBoxLayout, QHeaderView, QLabel, QSizePolicy, QSplitter,
                               QTableWidget, QTableWidgetItem, QVBoxLayout, QWidget)

from app.lab import VirtualLab
from app.pages.forms import WrappedLabel, scrolling
from app.pages.poses.texts import AXIS_LABELS, PLACEHOLDER, SHORT, comparison_html, facts_html, loaded_html
from core.poses.candidates import arm_polyline
from core.poses.file import PoseList
from core.poses.selection import PoseSelectionResult, lower_is_better
from core.robot.model import RobotModel
from widgets.index_curve_plot import IndexCurvePlot
from widgets.workspace_views import WorkspaceViews, camera_wedges


class SelectionResults(QWidget):
    """Draws a selection (`PoseSelectionResult`) or the poses of a project's poses.csv.

    The views are the top (x–z) and side (z–y) of the left camera frame, mm: the lab's cameras
    with their fields of view, the candidate and selected marker positions, the arm of the pose
    selected in the table. `set_selection(...)` draws everything; `set_index(key)` shows the
    curve of another index for the same selection.
    """

    def __init__(self, parent: QWidget | None = None):
        super().__init__(parent)
        self.result: PoseSelectionResult | None = None
        self.loaded: PoseList | None = None
        self.lab: VirtualLab | None = None
        self.robot: RobotModel | None = None      # the nominal robot, when there is no selection
        self.index = "cond"

        self.curve_plot = IndexCurvePlot()
        self.curve_plot.setMinimumHeight(170)
        self.summary = QLabel()
        self.summary.setObjectName("summaryLabel")
        self.summary.setWordWrap(True)
        self.summary.setTextFormat(Qt.TextFormat.RichText)
        self.summary.setAlignment(Qt.AlignmentFlag.AlignTop | Qt.AlignmentFlag.AlignLeft)
        self.summary.setTextInteractionFlags(Qt.TextInteractionFlag.TextSelectableByMouse)
        self.summary.setSizePolicy(QSizePolicy.Policy.Preferred, QSizePolicy.Policy.Preferred)
        self.facts = WrappedLabel()         # the page scrolls rather than squeeze the views
        self.facts.setObjectName("hint")
        self.facts.setWordWrap(True)
        self.facts.setTextFormat(Qt.TextFormat.RichText)
        self.views = WorkspaceViews()
        self.views.setMinimumHeight(190)
        self.table = QTableWidget(0, 0)
        self.table.setObjectName("posesTable")
        self.table.setEditTriggers(QAbstractItemView.EditTrigger.NoEditTriggers)
        self.table.setSelectionBehavior(QAbstractItemView.SelectionBehavior.SelectRows)
        self.table.setSelectionMode(QAbstractItemView.SelectionMode.SingleSelection)
        self.table.verticalHeader().setVisible(False)
        self.table.horizontalHeader().setSectionResizeMode(QHeaderView.ResizeMode.Stretch)
        self.table.itemSelectionChanged.connect(self._row_changed)
        self.table.setMinimumHeight(90)

        upper = QWidget()
        ul = QHBoxLayout(upper)
        ul.setContentsMargins(0, 0, 0, 0)
        ul.setSpacing(8)
        ul.addWidget(self.curve_plot, 3)
        ul.addWidget(scrolling(self.summary), 2)
        self.splitter = QSplitter(Qt.Orientation.Vertical)
        self.splitter.addWidget(upper)
        self.splitter.addWidget(self.views)
        self.splitter.addWidget(self.table)
        self.splitter.setChildrenCollapsible(False)
        self.splitter.setStretchFactor(0, 4)
        self.splitter.setStretchFactor(1, 5)
        self.splitter.setStretchFactor(2, 3)
        self.splitter.setSizes([230, 230, 150])

        layout = QVBoxLayout(self)
        layout.setContentsMargins(0, 0, 0, 0)
        layout.setSpacing(6)
        layout.addWidget(self.splitter, 1)
        layout.addWidget(self.facts)

    def set_selection(self, result: PoseSelectionResult | None, loaded: PoseList | None = None, *,
                      lab: VirtualLab | None = None, robot: RobotModel | None = None, index: str = "cond") -> None:
        """Draw `result` (or else the `loaded` poses of `robot`), in `lab` when there is one."""
        self.result, self.loaded, self.lab, self.robot, self.index = result, loaded, lab, robot, index
        self._show_curve()
        self._show_summary()
        self._fill_table()
        self._show_views()

    def set_index(self, key: str) -> None:
        """Show the curve of index `key` for the current selection (the selection itself
        optimised the index it was run with)."""
        self.index = key
        self._show_curve()

    def highlight(self, row: int) -> None:
        """Select table row `row` (its arm is drawn in the views)."""
        self.table.selectRow(row)

    # -- drawing ---------------------------------------------------------------------------
    def _show_curve(self) -> None:
        r = self.result
        if r is None:
            self.curve_plot.clear_curve()
            return
        key = self.index
        c = r.curve
        label = "selected poses" + ("" if key == r.index else f" (chosen by {SHORT[r.index]})")
        self.curve_plot.set_curve(c.n, c.selected[key], c.random_median[key], c.random_q25[key], c.random_q75[key],
                                  count=r.count, y_label=AXIS_LABELS[key], log_y=(key == "cond"),
                                  selected_label=label, legend_corner="right" if lower_is_better(key) else "left",
                                  random_label=f"random selections: median of {r.random.trials}")

    def _show_summary(self) -> None:
        r = self.result
        self.facts.setText(facts_html(r) if r is not None else "")
        self.facts.setVisible(r is not None)
        if r is not None:
            self.summary.setText(comparison_html(r))
        elif self.loaded is not None:
            self.summary.setText(loaded_html(len(self.loaded), self.loaded.path))
        else:
            self.summary.setText(PLACEHOLDER)

    def _robot_for_views(self) -> RobotModel | None:
        if self.result is not None:
            return self.result.robot
        if self.lab is not None:
            return self.lab.nominal_robot
        return self.robot

    def _fill_table(self) -> None:
        r = self.result
        robot = self._robot_for_views()
        q_file = r.q_file if r is not None else (self.loaded.q_file if self.loaded is not None else None)
        self.table.blockSignals(True)
        self.table.clearSelection()
        if q_file is None or robot is None:
            self.table.setRowCount(0)
            self.table.setColumnCount(0)
            self.table.blockSignals(False)
            return
        depth = r.depth if r is not None else None
        if depth is None and r is None and self.lab is not None:
            depth = robot.target_positions(self.loaded.Q, self.lab.target)[:, 2]
        headers = ["Pose"] + [f"q{j + 1} ({'°' if jt.revolute else 'mm'})" for j, jt in enumerate(robot.joints)]
        if depth is not None:
            headers.append("Depth (mm)")
        self.table.setColumnCount(len(headers))
        self.table.setHorizontalHeaderLabels(headers)
        self.table.setRowCount(len(q_file))
        for i, row in enumerate(q_file):
            cells = [str(i)] + [f"{v:.3f}" for v in row] + ([f"{depth[i]:.0f}"] if depth is not None else [])
            for j, text in enumerate(cells):
                item = QTableWidgetItem(text)
                item.setTextAlignment(Qt.AlignmentFlag.AlignRight | Qt.AlignmentFlag.AlignVCenter)
                self.table.setItem(i, j, item)
        self.table.blockSignals(False)
        if len(q_file):
            self.table.selectRow(0)

    def _selected_Q(self) -> np.ndarray | None:
        if self.result is not None:
            return self.result.Q
        if self.loaded is not None:
            return self.loaded.Q
        return None

    def _target(self, robot: RobotModel) -> str | None:
        return self.result.targets[0] if self.result is not None else next(iter(robot.targets), None)

    def _show_views(self) -> None:
        robot = self._robot_for_views()
        Q = self._selected_Q()
        lab = self.lab
        if robot is None or Q is None:
            self.views.set_scene(wedges=camera_wedges(lab.rig) if lab is not None else None)
            return
        target = self._target(robot)
        markers = robot.target_positions(Q, target) if target else np.zeros((0, 3))
        candidates = self.result.candidates.marker if self.result is not None else None
        depth = 1000.0
        if self.result is not None and self.result.depth is not None and len(self.result.depth):
            depth = float(max(900.0, np.max(self.result.depth) * 1.1))
        arms, _ = arm_polyline(robot, Q, target)
        self.views.set_scene(wedges=camera_wedges(lab.rig, depth) if lab is not None else None,
                             candidates=candidates, selected=markers, extent=arms.reshape(-1, 3))
        self._row_changed()

    def _row_changed(self) -> None:
        robot = self._robot_for_views()
        Q = self._selected_Q()
        rows = self.table.selectionModel().selectedRows() if self.table.selectionModel() else []
        if robot is None or Q is None or not rows:
            self.views.set_highlight(None)
            return
        i = rows[0].row()
        if not 0 <= i < len(Q):
            return
        target = self._target(robot)
        pts, _ = arm_polyline(robot, Q[i:i + 1], target)
        self.views.set_highlight(pts[0], pts[0, -1:] if target else None)
