"""The Pose sequence page's settings: how many poses, by which index, from how many candidates."""
from __future__ import annotations

from PySide6.QtCore import Signal
from PySide6.QtWidgets import QComboBox, QLabel, QWidget

from app.pages import forms
from app.pages.poses.model import DEMO_CANDIDATES, DEMO_COUNT, PoseOptions
from app.pages.poses.texts import INDEX_CHOICES
from widgets.flow_layout import FlowLayout


class SelectionControls(QWidget):
    """N, index, candidates, joint margin (° or mm), seed and the Select button.

    Signals: `selectRequested()` (Select clicked), `indexChanged()` (another index chosen).
    """

    selectRequested = Signal()
    indexChanged = Signal()

    def __init__(self, parent: QWidget | None = None):
        super().__init__(parent)
        self.count_spin = forms.spin(DEMO_COUNT, 1, 500, name="countSpin",
                                     tooltip="How many poses the robot will be measured in")
        self.index_combo = QComboBox()
        self.index_combo.setObjectName("indexCombo")
        for key, text in INDEX_CHOICES:
            self.index_combo.addItem(text, key)
        self.index_combo.setToolTip("The observability index the selection optimises (see Explain)")
        self.candidates_spin = forms.spin(DEMO_CANDIDATES, 50, 20000, name="candidatesSpin", step=500,
                                          tooltip="Feasible random configurations to choose from")
        self.margin_spin = forms.double_spin(5.0, 0.0, 45.0, decimals=1, step=1.0, name="marginSpin",
                                             suffix=" °", tooltip="Distance kept from every joint limit "
                                                                  "(mm for prismatic joints)")
        self.seed_spin = forms.spin(0, 0, 1_000_000, name="seedSpin",
                                    tooltip="Seed of the random candidates: the same seed gives the same poses")
        self.select_button = forms.button("Select poses", "selectButton", on_click=self.selectRequested.emit)
        self.index_combo.currentIndexChanged.connect(lambda *_: self.indexChanged.emit())

        flow = FlowLayout(self)           # wraps on a narrow window
        flow.setContentsMargins(0, 0, 0, 0)
        flow.add_group(QLabel("Poses N:"), self.count_spin)
        flow.add_group(QLabel("Index:"), self.index_combo)
        flow.addWidget(self.select_button)
        flow.add_group(QLabel("Candidates:"), self.candidates_spin)
        flow.add_group(QLabel("Joint margin:"), self.margin_spin)
        flow.add_group(QLabel("Seed:"), self.seed_spin)

    def index(self) -> str:
        return self.index_combo.currentData()

    def set_index(self, key: str) -> None:
        self.index_combo.setCurrentIndex(self.index_combo.findData(key))

    def options(self) -> PoseOptions:
        """The selection's settings chosen here."""
        return PoseOptions(self.count_spin.value(), self.index(), self.candidates_spin.value(),
                           self.margin_spin.value(), self.seed_spin.value())

    def show_options(self, options: PoseOptions) -> None:
        self.count_spin.setValue(options.count)
        self.set_index(options.index)
        self.candidates_spin.setValue(options.candidates)
        self.margin_spin.setValue(options.margin)
        self.seed_spin.setValue(options.seed)

    def set_demo(self) -> None:
        """The settings of the classroom demo (autopilot): 30 poses by κ from 1000 candidates (the
        margin and the seed kept)."""
        shown = self.options()
        self.show_options(PoseOptions(DEMO_COUNT, "cond", DEMO_CANDIDATES, shown.margin, shown.seed))

    def set_busy(self, busy: bool) -> None:
        """Settings and Select are locked while a selection runs."""
        for w in (self.select_button, self.count_spin, self.index_combo, self.candidates_spin, self.margin_spin,
                  self.seed_spin):
            w.setEnabled(not busy)
