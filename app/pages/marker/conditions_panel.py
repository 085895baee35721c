"""The Marker page's Conditions tab: the marker under dimmer light, partly covered and tilted
away from the cameras (virtual lab). Show pair renders and locates one pair under the chosen
conditions; Sweep runs the robustness sweep over all three and shows its table and plots, so a
class can see where the marker method breaks."""
from __future__ import annotations

import numpy as np
from PySide6.QtCore import Qt, Signal
from PySide6.QtWidgets import (QAbstractItemView, QComboBox, QHBoxLayout, QHeaderView, QLabel, QSlider, QSplitter,
                               QTableWidget, QTableWidgetItem, QVBoxLayout, QWidget)

from app.html import esc, number
from app.jobs.marker_conditions import ConditionsPair
from app.lab import SIDES, ImagingConditions, RobustnessTable
from app.pages.forms import button, spin
from app.pages.marker.model import ConditionsOptions
from widgets.flow_layout import FlowLayout
from widgets.image_view import ImageView
from widgets.robustness_plot import RobustnessPlot

HEADERS = ["Condition", "Pairs", "Detected", "Median 3D error", "95th percentile", "Wrong", "Most frequent rejection"]
AXES = {"light": "light (× normal)", "occlusion": "marker covered (%)", "tilt": "tilt from facing the cameras (°)"}
RANDOM_TILT = -1                   # the tilt spin's special value: a random tilt up to 30°
NOTE = ("<b>Detected</b>: located and passing every check, of the pairs rendered. <b>3D error</b>: distance of the "
        f"located point from the lab's true marker position. <b>Wrong</b>: accepted more than "
        f"{RobustnessTable.wrong_mm:g} mm off — a silent "
        "wrong number a calibration would use; it must stay 0: where the method cannot see the marker well it "
        "must say why instead.")


class ConditionsPanel(QWidget):
    """The Conditions tab; the page connects `show_button` and `sweep_button` and calls
    `draw_pair(pair)` and `draw_table(table)`. `options()` the conditions and sweep chosen
    (`optionsChanged()` on a change), `show_options(o)` binds them back."""

    optionsChanged = Signal()

    def __init__(self, parent: QWidget | None = None):
        super().__init__(parent)
        start = ConditionsOptions()
        self.light_slider = QSlider(Qt.Orientation.Horizontal)
        self.light_slider.setObjectName("lightSlider")
        self.light_slider.setRange(5, 150)
        self.light_slider.setValue(round(100 * start.conditions.light))
        self.light_slider.setToolTip("Light on the scene, % of the lab's normal light (the sensor noise stays)")
        self.light_slider.setMinimumWidth(140)
        self.light_label = QLabel()
        self.light_slider.valueChanged.connect(self._light_changed)
        self._light_changed(self.light_slider.value())
        self.occlusion_spin = spin(round(100 * start.conditions.occlusion), 0, 90, name="occlusionSpin", suffix=" %",
                                   tooltip="Share of the marker's outer square covered by a dark band or patch")
        self.side_combo = QComboBox()
        self.side_combo.setObjectName("sideCombo")
        self.side_combo.addItems(SIDES)
        self.side_combo.setCurrentText(start.conditions.side)
        self.side_combo.setToolTip("Where the occluder lies: a band along one side of the marker, or over a corner")
        self.tilt_spin = spin(RANDOM_TILT, RANDOM_TILT, 85, name="tiltSpin", suffix="°",
                              tooltip="Angle between the marker's normal and the direction to the cameras")
        self.tilt_spin.setSpecialValueText("random ≤ 30°")
        self.tilt_spin.setValue(RANDOM_TILT if start.conditions.tilt is None else round(start.conditions.tilt))
        self.show_button = button("Show pair", "showConditionsButton",
                                  tooltip="Render one marker pair under these conditions and locate it")
        self.pairs_spin = spin(start.sweep_pairs, 1, 200, name="sweepPairsSpin",
                               tooltip="Pairs rendered per condition value in the sweep")
        self.sweep_button = button("Sweep", "sweepButton",
                                   tooltip="Detection rate and 3D error over light levels, occlusions and tilts")
        self.axis_combo = QComboBox()
        self.axis_combo.setObjectName("axisCombo")
        for key, label in AXES.items():
            self.axis_combo.addItem(label, key)
        self.axis_combo.currentIndexChanged.connect(lambda *_: self._draw_plot())
        self.pair_view = ImageView()
        self.pair_view.setObjectName("conditionsImage")
        self.pair_view.add_points("reference", colour="#d93025", symbol="+", size=14)
        self.pair_text = QLabel()
        self.pair_text.setObjectName("conditionsPairText")
        self.pair_text.setWordWrap(True)
        self.pair_text.setTextFormat(Qt.TextFormat.RichText)
        self.plot = RobustnessPlot()
        self.table = QTableWidget(0, len(HEADERS))
        self.table.setObjectName("robustnessTable")
        self.table.setHorizontalHeaderLabels(HEADERS)
        self.table.setEditTriggers(QAbstractItemView.EditTrigger.NoEditTriggers)
        self.table.verticalHeader().setVisible(False)
        self.table.horizontalHeader().setSectionResizeMode(QHeaderView.ResizeMode.ResizeToContents)
        self.table.horizontalHeader().setStretchLastSection(True)
        note = QLabel(NOTE)
        note.setObjectName("hint")
        note.setWordWrap(True)
        self.result: RobustnessTable | None = None
        for changed in (self.light_slider.valueChanged, self.occlusion_spin.valueChanged,
                        self.side_combo.currentTextChanged, self.tilt_spin.valueChanged, self.pairs_spin.valueChanged):
            changed.connect(lambda *_: self.optionsChanged.emit())

        layout = QVBoxLayout(self)
        layout.setContentsMargins(4, 4, 4, 4)
        choices = FlowLayout()          # wraps on a narrow window
        choices.add_group(QLabel("Light:"), self.light_slider, self.light_label)
        choices.add_group(QLabel("Covered:"), self.occlusion_spin, self.side_combo)
        choices.add_group(QLabel("Tilt:"), self.tilt_spin)
        choices.addWidget(self.show_button)
        layout.addLayout(choices)
        sweep = FlowLayout()
        sweep.add_group(QLabel("Sweep with"), self.pairs_spin, QLabel("pairs per value:"), self.sweep_button)
        sweep.add_group(QLabel("Plot against:"), self.axis_combo)
        layout.addLayout(sweep)
        split = QSplitter(Qt.Orientation.Horizontal)
        left = QWidget()
        lv = QVBoxLayout(left)
        lv.setContentsMargins(0, 0, 0, 0)
        lv.addWidget(self.pair_view, 1)
        lv.addWidget(self.pair_text)
        split.addWidget(left)
        split.addWidget(self.plot)
        split.setSizes([380, 520])
        body = QHBoxLayout()
        body.addWidget(split)
        layout.addLayout(body, 3)
        layout.addWidget(self.table, 2)
        layout.addWidget(note)
        self.draw_pair(None)

    def _light_changed(self, value: int) -> None:
        self.light_label.setText(f"{value / 100:.2f}×")

    def conditions(self) -> ImagingConditions:
        """The conditions chosen in the controls (they keep them within bounds)."""
        tilt = self.tilt_spin.value()
        return ImagingConditions(light=self.light_slider.value() / 100.0, occlusion=self.occlusion_spin.value() / 100.0,
                                 side=self.side_combo.currentText(), tilt=None if tilt == RANDOM_TILT else float(tilt))

    def options(self) -> ConditionsOptions:
        return ConditionsOptions(self.conditions(), self.pairs_spin.value())

    def show_options(self, options: ConditionsOptions) -> None:
        c = options.conditions
        self.light_slider.setValue(round(100 * c.light))
        self.occlusion_spin.setValue(round(100 * c.occlusion))
        self.side_combo.setCurrentText(c.side)
        self.tilt_spin.setValue(RANDOM_TILT if c.tilt is None else round(c.tilt))
        self.pairs_spin.setValue(options.sweep_pairs)

    def draw_pair(self, pair: ConditionsPair | None) -> None:
        """The left image of the pair with the located reference point, and what was found."""
        if pair is None:
            self.pair_view.set_image(None)
            self.pair_view.set_points("reference", np.zeros((0, 2)))
            self.pair_text.setText("<span style='color:#5f6368'>Choose the light, the covered share and the tilt, "
                                   "then Show pair.</span>")
            return
        self.pair_view.set_image(pair.left)
        loc = pair.location
        c = pair.conditions
        head = (f"Light {c.light:.2f}×, {100 * c.occlusion:.0f} % covered ({esc(c.side)}), tilt {pair.tilt:.0f}°: ")
        if loc.ok:
            self.pair_view.set_points("reference", loc.left_point[None])
            self.pair_text.setText(head + f"<b>located</b>, {number(pair.error, 3, 'mm')} from the true position.")
        else:
            self.pair_view.set_points("reference", np.zeros((0, 2)))
            self.pair_text.setText(head + f"<b style='color:#c5221f'>not located</b> ({esc(loc.stage)}): "
                                   f"{esc(loc.reason)}")

    def draw_table(self, table: RobustnessTable | None) -> None:
        """One row per condition value, and the plot of the chosen condition."""
        self.result = table
        rows = [] if table is None else table.rows
        self.table.setRowCount(len(rows))
        for i, r in enumerate(rows):
            label = {"light": f"light {r.value:g}×", "occlusion": f"{100 * r.value:g} % covered ({table.side})",
                     "tilt": f"tilt {r.value:g}°"}[r.axis]
            reason = r.top_reason
            cells = [label, str(r.rendered), f"{100 * r.detection_rate:.0f} %", number(r.median_error, 3, "mm"),
                     number(r.p95_error, 3, "mm"), str(r.wrong), reason]
            for j, text in enumerate(cells):
                item = QTableWidgetItem(text)
                if 0 < j < 6:
                    item.setTextAlignment(Qt.AlignmentFlag.AlignRight | Qt.AlignmentFlag.AlignVCenter)
                if j == 5 and r.wrong:
                    item.setForeground(Qt.GlobalColor.red)
                if j == 6:
                    item.setToolTip("\n".join(f"{n}× {r.examples[k]}" for k, n in r.reasons.most_common()))
                self.table.setItem(i, j, item)
        self._draw_plot()

    def _draw_plot(self) -> None:
        key = self.axis_combo.currentData()
        rows = [] if self.result is None else self.result.axis(key)
        scale = 100.0 if key == "occlusion" else 1.0
        self.plot.set_rows([scale * r.value for r in rows], [r.detection_rate for r in rows],
                           [r.median_error for r in rows], [r.p95_error for r in rows],
                           [r.wrong / r.rendered if r.rendered else np.nan for r in rows], AXES[key])
