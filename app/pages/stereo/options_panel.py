"""The Stereo page's camera model row: radial and tangential coefficients, fixed aspect ratio
and principal point (`options()`, `show_options(o)`: the step model's options), the Calibrate
button and the page's progress row."""
from __future__ import annotations

from PySide6.QtWidgets import QCheckBox, QComboBox, QLabel, QVBoxLayout, QWidget

from app.pages.forms import button
from core.stereo.coverage import MIN_PAIRS_TO_CALIBRATE
from core.stereo.fit import CalibrationOptions
from widgets.flow_layout import FlowLayout


class OptionsPanel(QWidget):
    """The model the user chooses (`options()`) and the Calibrate button; the progress row
    (bar and Cancel) of the page goes below them. The row wraps on a narrow window."""

    def __init__(self, progress_row: QWidget, parent=None):
        super().__init__(parent)
        self.setObjectName("optionsRow")
        self.radial_combo = QComboBox()
        for text, value in (("2: k1 k2", 2), ("3: k1 k2 k3", 3), ("6: rational", 6)):
            self.radial_combo.addItem(text, value)
        self.radial_combo.setCurrentIndex(1)
        self.radial_combo.setToolTip("Radial distortion coefficients: 2 for narrow lenses, 3 usually, 6 for "
                                     "strong wide-angle distortion (needs many well-spread pairs)")
        self.tangential_check = _check("tangential", "Estimate the tangential coefficients p1, p2: decentring "
                                                     "distortion of a lens not exactly square to the sensor")
        self.tangential_check.setChecked(True)
        self.aspect_check = _check("fx = fy", "Fix the aspect ratio: keep fx = fy (square pixels)")
        self.principal_check = _check("fix centre", "Fix the principal point: keep (cx, cy) at the image centre: "
                                                    "steadier with few or poorly spread pairs")
        self.calibrate_button = button("Calibrate", "calibrateButton")
        self.calibrate_button.setDefault(True)
        heading = QLabel("Camera model")
        heading.setObjectName("sectionHeading")
        line = FlowLayout()
        line.addWidget(heading)
        line.add_group(QLabel("radial:"), self.radial_combo)
        for w in (self.tangential_check, self.aspect_check, self.principal_check, self.calibrate_button):
            line.addWidget(w)
        layout = QVBoxLayout(self)
        layout.setContentsMargins(0, 0, 0, 0)
        layout.addLayout(line)
        layout.addWidget(progress_row)

    def options(self) -> CalibrationOptions:
        return CalibrationOptions(radial=int(self.radial_combo.currentData()),
                                  tangential=self.tangential_check.isChecked(),
                                  fix_aspect=self.aspect_check.isChecked(),
                                  fix_principal=self.principal_check.isChecked())

    def show_options(self, options: CalibrationOptions) -> None:
        """Show the camera model `options` (the choices this row has; the others are the core's)."""
        self.radial_combo.setCurrentIndex(max(0, self.radial_combo.findData(options.radial)))
        self.tangential_check.setChecked(options.tangential)
        self.aspect_check.setChecked(options.fix_aspect)
        self.principal_check.setChecked(options.fix_principal)

    def set_enabled(self, enabled: bool) -> None:
        """The model can be changed only while no task runs."""
        for w in (self.radial_combo, self.tangential_check, self.aspect_check, self.principal_check):
            w.setEnabled(enabled)

    def show_calibrate(self, busy: bool, usable: int, enough: bool) -> None:
        """The Calibrate button for `usable` accepted pairs whose coverage is `enough` (or not)."""
        b = self.calibrate_button
        b.setEnabled(not busy and usable >= MIN_PAIRS_TO_CALIBRATE)
        b.setText("Calibrate" if enough or usable < MIN_PAIRS_TO_CALIBRATE else "Calibrate (low coverage)")
        b.setToolTip(f"Needs at least {MIN_PAIRS_TO_CALIBRATE} accepted pairs" if usable < MIN_PAIRS_TO_CALIBRATE
                     else ("Enough views: calibrate" if enough else
                           "Possible, but coverage is not enough yet: the result may be poorly determined"))


def _check(text: str, tooltip: str) -> QCheckBox:
    box = QCheckBox(text)
    box.setToolTip(tooltip)
    return box
