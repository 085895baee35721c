"""The Check page's Fixture panel: where a fixture is in the robot's base frame, from the virtual
lab's fixture or from a fixture description and a folder of image pairs (app/jobs/fixture.py); the
located fixture drawn from the model's events (`follow(model)`)."""
from __future__ import annotations

import numpy as np
from PySide6.QtWidgets import QComboBox, QFileDialog, QGroupBox, QLabel, QVBoxLayout

from app.html import esc
from app.pages import forms
from app.pages.check.model import CheckModel

SOURCES = [("virtual lab fixture", "lab"), ("image pairs", "files")]


class FixturePanel(QGroupBox):
    def __init__(self, parent=None):
        super().__init__("Fixture", parent)
        self.description_path: str | None = None
        self.pairs_folder: str | None = None
        note = QLabel("Locate a fixture's marker points in the robot's base frame and write its pose "
                      "(fixture_pose.json, fixture.urdf) to the project.")
        note.setWordWrap(True)
        self.source_combo = QComboBox()
        self.source_combo.setObjectName("fixtureSource")
        for label, _ in SOURCES:
            self.source_combo.addItem(label)
        self.description_button = forms.button("Description…", "fixtureDescriptionButton",
                                               on_click=self._choose_description,
                                               tooltip="The fixture description: point names and their "
                                                       "positions on the fixture (mm)")
        self.pairs_button = forms.button("Pairs folder…", "fixturePairsButton", on_click=self._choose_pairs,
                                         tooltip="A folder with left/<point>.png and right/<point>.png")
        self.files_label = QLabel()
        self.files_label.setWordWrap(True)
        self.locate_button = forms.button("Locate fixture", "locateFixtureButton",
                                          tooltip="Locate every marker point and fit the fixture frame")
        self.result_label = QLabel("No fixture located yet.")
        self.result_label.setObjectName("fixtureResult")
        self.result_label.setWordWrap(True)
        layout = QVBoxLayout(self)
        layout.addWidget(note)
        layout.addWidget(self.source_combo)
        layout.addLayout(forms.row(self.description_button, self.pairs_button))
        layout.addWidget(self.files_label)
        layout.addWidget(self.locate_button)
        layout.addWidget(self.result_label)
        self.source_combo.currentIndexChanged.connect(lambda *_: self._source_changed())
        self._source_changed()

    @property
    def source(self) -> str:
        return SOURCES[self.source_combo.currentIndex()][1]

    def _source_changed(self) -> None:
        files = self.source == "files"
        self.description_button.setEnabled(files)
        self.pairs_button.setEnabled(files)
        self._show_files()

    def _show_files(self) -> None:
        if self.source != "files":
            self.files_label.setText("The lab's fixture: four markers on a plate in front of the cameras.")
            return
        self.files_label.setText(f"Description: {self.description_path or '—'}<br>Pairs: {self.pairs_folder or '—'}")

    def _choose_description(self) -> None:
        path, _ = QFileDialog.getOpenFileName(self, "Fixture description", "", "Fixture description (*.json)")
        if path:
            self.description_path = path
            self._show_files()

    def _choose_pairs(self) -> None:
        path = QFileDialog.getExistingDirectory(self, "Folder of image pairs")
        if path:
            self.pairs_folder = path
            self._show_files()

    def set_virtual(self, virtual: bool) -> None:
        """A real cell has no lab fixture: only image pairs are offered (and chosen)."""
        item = self.source_combo.model().item(0)
        item.setEnabled(virtual)
        if not virtual and self.source == "lab":
            self.source_combo.setCurrentIndex(1)

    def set_enabled(self, busy: bool, ready: bool) -> None:
        self.locate_button.setEnabled(ready and not busy)
        self.source_combo.setEnabled(not busy)

    def follow(self, model: CheckModel) -> None:
        model.on("fixture", self.show_run)

    def show_run(self, run) -> None:
        """The located fixture: pose ± σ, residuals per point, the files written, the lab's truth."""
        f = run.result.frame
        p, sp = f.position, f.sigma_position_mm
        r, sr = f.rpy_deg, f.sigma_rotation_deg
        lines = [f"<b>{esc(run.result.description.name)}</b> ({f.method}, {len(f.names)} points)",
                 "position " + ", ".join(f"{v:.3f} ± {s:.3f}" for v, s in zip(p, sp)) + " mm",
                 "roll, pitch, yaw " + ", ".join(f"{v:.3f} ± {s:.3f}" for v, s in zip(r, sr)) + "°"]
        if f.method == "rigid fit":
            worst = int(np.argmax(f.residual_norms_mm))
            lines.append(f"RMS residual {f.rms_mm:.3f} mm; largest {f.residual_norms_mm[worst]:.3f} mm at "
                         f"{esc(f.names[worst])}")
        if run.true_error is not None:
            lines.append(f"against the lab's true pose: {np.linalg.norm(run.true_error[:3]):.3f} mm, "
                         f"{np.rad2deg(np.linalg.norm(run.true_error[3:])):.4f}°")
        lines.append(f"wrote {esc(run.pose_path.name)} and {esc(run.urdf_path.name)}")
        self.result_label.setText("<br>".join(lines))
