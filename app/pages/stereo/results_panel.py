"""The Stereo page's results: errors per pair (with the draggable threshold to drop pairs),
the summary, the parameter table ± σ, the rectified preview and the residual scatter.
`ResultsPanel` draws a `StereoCalibrationResult`; the page's ResultActions (result_actions.py)
drops and restores pairs from it and rectifies the previewed pair on a worker."""
from __future__ import annotations

import numpy as np
from PySide6.QtCore import Qt
from PySide6.QtWidgets import QComboBox, QHBoxLayout, QLabel, QTabWidget, QTextBrowser, QVBoxLayout, QWidget

from app.pages.forms import button, row, scrolling
from app.pages.stereo.texts import GROUP_NAMES, PARAM_NAMES, UNIT_NAMES, residual_stats_html, summary_html
from widgets.error_bar_chart import ErrorBarChart
from widgets.image_view import ImageView
from widgets.residual_scatter import ResidualScatter
from widgets.value_table import ValueTable

LINE_SPACING = 40           # px between the epipolar lines of the rectified preview
PREVIEW_GAP = 8             # px between the rectified left and right images
TABLE_NOTE = (
    "<b>± σ</b> is one standard deviation of each parameter, from the Jacobian of the joint fit "
    "(eq. 21). Small σ of f<sub>x</sub>, f<sub>y</sub>, c<sub>x</sub>, c<sub>y</sub> and k<sub>1</sub> "
    "matters more than a low RMS. A σ as large as its value (often k<sub>3</sub>) means the pairs do "
    "not determine that coefficient: add tilted views near the image edges, or estimate fewer "
    "coefficients.<br><br>R is given as a rotation vector (axis × angle, degrees); T and the "
    "baseline in mm, X<sub>right</sub> = R·X<sub>left</sub> + T. Greyed values were fixed.")


class ResultsPanel(QTabWidget):
    """Tabs: Errors per pair, Summary, Parameters ± σ, Rectified pair, Residuals."""

    def hasHeightForWidth(self) -> bool:
        """No height for width: a box layout would hold the tabs at their preferred height (their
        wrapped notes') as a minimum and squeeze the pairs above them on a small screen."""
        return False

    def __init__(self, parent=None):
        super().__init__(parent)
        self.setObjectName("resultTabs")
        self.addTab(self._errors_tab(), "Errors per pair")
        self.summary_view = QTextBrowser()
        self.summary_view.setObjectName("summaryView")
        self.summary_view.setOpenLinks(False)
        self.addTab(self.summary_view, "Summary")
        self.addTab(self._table_tab(), "Parameters ± σ")
        self.addTab(self._preview_tab(), "Rectified pair")
        self.addTab(self._scatter_tab(), "Residuals")

    def _errors_tab(self) -> QWidget:
        self.errors_chart = ErrorBarChart()
        self.drop_button = button("Drop selected && recalibrate", "dropButton",
                                  tooltip="Drag the black line down: pairs with a bar above it are dropped")
        self.flagged_button = button("Select flagged", tooltip="Move the line just below the pairs flagged as "
                                                               "outliers")
        self.restore_button = button("Restore dropped", tooltip="Bring back every pair you dropped (then "
                                                                "Calibrate again)")
        self.outlier_label = _hint()
        tab = QWidget()
        layout = QVBoxLayout(tab)
        layout.setContentsMargins(4, 4, 4, 4)
        layout.addWidget(self.errors_chart, 1)
        buttons = row(stretch=False)
        buttons.addWidget(self.outlier_label, 1)
        for b in (self.flagged_button, self.restore_button, self.drop_button):
            buttons.addWidget(b)
        layout.addLayout(buttons)
        return tab

    def _table_tab(self) -> QWidget:
        self.table = ValueTable(group_names=GROUP_NAMES, display_names=PARAM_NAMES, unit_names=UNIT_NAMES)
        self.table.setObjectName("stereoParameterTable")
        note = _hint(TABLE_NOTE)
        note.setAlignment(Qt.AlignmentFlag.AlignTop | Qt.AlignmentFlag.AlignLeft)
        tab = QWidget()
        layout = QHBoxLayout(tab)
        layout.setContentsMargins(4, 4, 4, 4)
        layout.addWidget(self.table, 3)
        layout.addWidget(scrolling(note), 2)
        return tab

    def _preview_tab(self) -> QWidget:
        self.preview = ImageView()
        self.preview.add_lines("epipolar", colour="#34a853", width=1.0)
        self.preview.add_points("left_corners", colour="#ea4335", symbol="o", size=4, width=0)
        self.preview.add_points("right_corners", colour="#ea4335", symbol="o", size=4, width=0)
        self.preview_combo = QComboBox()
        self.preview_combo.setObjectName("previewCombo")
        self.preview_combo.setMinimumContentsLength(24)
        self.preview_caption = _hint()
        tab = QWidget()
        layout = QVBoxLayout(tab)
        layout.setContentsMargins(4, 4, 4, 4)
        line = row("Pair:", self.preview_combo, stretch=False)
        line.addWidget(self.preview_caption, 1)
        layout.addLayout(line)
        layout.addWidget(self.preview, 1)
        return tab

    def _scatter_tab(self) -> QWidget:
        self.scatter = ResidualScatter()
        self.scatter_caption = _hint()
        self.scatter_stats = QLabel()
        self.scatter_stats.setObjectName("scatterStats")
        self.scatter_stats.setAlignment(Qt.AlignmentFlag.AlignTop | Qt.AlignmentFlag.AlignLeft)
        self.scatter_stats.setWordWrap(True)
        self.scatter_stats.setTextInteractionFlags(Qt.TextInteractionFlag.TextSelectableByMouse)
        tab = QWidget()
        layout = QVBoxLayout(tab)
        layout.setContentsMargins(4, 4, 4, 4)
        line = row(stretch=False)
        line.addWidget(self.scatter, 3)
        line.addWidget(scrolling(self.scatter_stats), 2)
        layout.addLayout(line, 1)
        layout.addWidget(self.scatter_caption)
        return tab

    # -- drawing ------------------------------------------------------------------------------
    def clear(self) -> None:
        """No calibration: empty tabs with what to do."""
        self.errors_chart.clear_errors()
        self.outlier_label.setText("Calibrate to see the reprojection error of every pair.")
        self.table.set_rows([])
        self.summary_view.setHtml("<p style='color:#5f6368'>No calibration yet. Add pairs until the coverage "
                                  "is enough, then Calibrate.</p>")
        self.preview_combo.blockSignals(True)
        self.preview_combo.clear()
        self.preview_combo.blockSignals(False)
        self.clear_preview()
        self.preview_caption.setText("")
        self.scatter.clear_residuals()
        self.scatter_caption.setText("")
        self.scatter_stats.setText("")

    def show_result(self, r) -> None:
        """Every tab of a calibration; the preview combo lists its pairs (no signal: the page
        asks for the preview of the first)."""
        pairs = [i + 1 for i in r.view_indices]
        self.errors_chart.set_errors(pairs, r.per_view_rms_left, r.per_view_rms_right,
                                     flagged=[i in r.outliers for i in r.view_indices],
                                     auto_threshold=r.outlier_threshold)
        self.outlier_label.setText(outlier_text(r))
        self.table.set_rows(r.parameters)
        self.summary_view.setHtml(summary_html(r))
        res_l, res_r = r.fit.residuals_left, r.fit.residuals_right
        self.scatter.set_residuals(res_l.reshape(-1, 2), res_r.reshape(-1, 2))
        n = res_l.shape[0] * res_l.shape[1]
        self.scatter_caption.setText(
            f"Observed − projected corner position, {n} corners per camera over {r.pairs_used} pairs. "
            "A round cloud centred on 0 is good; a pattern (a ring, a stripe, one direction) means the "
            "distortion model or some pairs are wrong. Circled: the pair shown in Rectified pair.")
        self.scatter_stats.setText(residual_stats_html(r))
        self.preview_combo.blockSignals(True)
        self.preview_combo.clear()
        for i, name in zip(r.view_indices, r.view_names):
            self.preview_combo.addItem(f"{i + 1}: {name}", i)
        self.preview_combo.blockSignals(False)
        self.preview_combo.setCurrentIndex(0)

    def show_controls(self, busy: bool, result, any_dropped: bool) -> None:
        """Drop (pairs above the line), Select flagged and Restore dropped, while no task runs."""
        has_result = result is not None
        self.drop_button.setEnabled(not busy and has_result and bool(self.errors_chart.selected()))
        self.flagged_button.setEnabled(not busy and has_result and bool(result.outliers if has_result else []))
        self.restore_button.setEnabled(not busy and any_dropped)

    def clear_preview(self) -> None:
        self.preview.set_image(None)
        for name in ("left_corners", "right_corners"):
            self.preview.set_points(name, None)
        self.preview.set_lines("epipolar", None)

    def draw_preview(self, r, v: int, left_r: np.ndarray, right_r: np.ndarray) -> None:
        """Pair `v` (row of the per-view arrays) rectified, side by side, with the epipolar
        lines and the rectified corners."""
        vertical = r.rectification.vertical
        h, w = left_r.shape[:2]
        gap = np.full((h, PREVIEW_GAP), 255, np.uint8)
        self.preview.set_image(np.concatenate([left_r, gap, right_r], axis=1))
        total_w = 2 * w + PREVIEW_GAP
        if vertical:
            xs = np.arange(LINE_SPACING / 2, w, LINE_SPACING)
            segs = [[[x, 0], [x, h]] for x in xs] + [[[x + w + PREVIEW_GAP, 0], [x + w + PREVIEW_GAP, h]] for x in xs]
            self.preview.set_lines("epipolar", np.array(segs))
        else:
            self.preview.set_horizontal_lines("epipolar", np.arange(LINE_SPACING / 2, h, LINE_SPACING), 0, total_w)
        self.preview.set_points("left_corners", r.epipolar.rectified_left[v])
        self.preview.set_points("right_corners", r.epipolar.rectified_right[v] + np.array([w + PREVIEW_GAP, 0.0]))
        err = r.epipolar.errors[v]
        self.preview_caption.setText(
            f"Rectified left | right. {'Vertical' if vertical else 'Horizontal'} green lines every "
            f"{LINE_SPACING} px; red dots: the detected corners, rectified. Epipolar error of this pair: RMS "
            f"{float(np.sqrt(np.mean(err ** 2))):.3f} px, max {float(np.max(np.abs(err))):.3f} px.")


def outlier_text(r) -> str:
    """Which pairs were flagged, and how to drop them."""
    if r is None:
        return ""
    if r.outliers:
        parts = [f"pair {i + 1} ({r.per_view_rms[r.view_position(i)]:.3f} px)" for i in r.outliers]
        return (f"Flagged automatically (RMS above {r.outlier_threshold:.3f} px = median + "
                f"{r.options.outlier_k:g}σ and ≥ {r.options.outlier_min_ratio:g}× median): {', '.join(parts)}. "
                "Drag the line below them to drop them.")
    return (f"No pair flagged as an outlier (threshold {r.outlier_threshold:.3f} px). Drag the line down to "
            "drop pairs with the largest errors.")


def _hint(text: str = "") -> QLabel:
    label = QLabel(text)
    label.setObjectName("hint")
    label.setWordWrap(True)
    return label
