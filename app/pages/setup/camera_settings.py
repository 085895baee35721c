"""The Setup page's camera settings: what to ask of both cameras (resolution, pixel format,
frame rate, exposure, gain, focus, white balance; auto focus off by default), and what each
camera really uses once open, with a warning for every setting that did not take
(core.measurement.capture applies them, MJPG before width and height)."""
from __future__ import annotations

from PySide6.QtWidgets import QCheckBox, QComboBox, QGridLayout, QLabel, QWidget

from app.html import esc
from app.pages import forms
from core.measurement.capture import CameraSettings

FORMATS = ("MJPG", "YUYV", "")                  # "": the camera's own
OWN = "camera's"                                # shown for "leave the camera's own value"
SHOWN = ("pixel format", "width", "height", "frame rate", "exposure", "gain", "focus", "white balance")


def _own(box, tooltip: str):
    box.setSpecialValueText(OWN)
    box.setToolTip(tooltip)
    return box


class CameraSettingsForm(QWidget):
    """Settings asked of both cameras (a stereo pair of the same model)."""

    def __init__(self, parent: QWidget | None = None):
        super().__init__(parent)
        self.width_spin = _own(forms.spin(0, 0, 8192, name="camWidth", suffix=" px"),
                               "Image width asked of the camera (the lab's webcams: 1280)")
        self.height_spin = _own(forms.spin(0, 0, 8192, name="camHeight", suffix=" px"),
                                "Image height asked of the camera (the lab's webcams: 1024)")
        self.format_combo = QComboBox()
        self.format_combo.setObjectName("camFormat")
        for f in FORMATS:
            self.format_combo.addItem(f or OWN, f)
        self.format_combo.setToolTip("MJPG keeps two USB cameras within the bus bandwidth; set before the size")
        self.fps_spin = _own(forms.double_spin(0.0, 0.0, 120.0, decimals=1, step=5.0, name="camFps", suffix=" fps"),
                             "Frame rate asked of the camera")
        self.exposure_spin = _own(forms.double_spin(0.0, 0.0, 10000.0, decimals=0, step=10.0, name="camExposure"),
                                  "Manual exposure (V4L2: 100 µs steps); camera's: locked at its current value")
        self.gain_spin = _own(forms.double_spin(0.0, 0.0, 1000.0, decimals=0, step=1.0, name="camGain"),
                              "Manual gain")
        self.focus_spin = _own(forms.double_spin(0.0, 0.0, 1000.0, decimals=0, step=5.0, name="camFocus"),
                               "Manual focus (auto focus off)")
        self.wb_spin = _own(forms.double_spin(0.0, 0.0, 10000.0, decimals=0, step=100.0, name="camWhiteBalance",
                                              suffix=" K"),
                            "White balance in kelvin; camera's: locked at its current value")
        self.autofocus_check = QCheckBox("Auto focus")
        self.autofocus_check.setObjectName("camAutofocus")
        self.autofocus_check.setToolTip("Leave off: a focus that moves changes the camera's calibration")
        self.autofocus_check.toggled.connect(lambda on: self.focus_spin.setEnabled(not on))
        grid = QGridLayout(self)
        grid.setContentsMargins(0, 0, 0, 0)
        cells = (("Size:", forms.row(self.width_spin, "×", self.height_spin, stretch=False)),
                 ("Format:", self.format_combo), ("Rate:", self.fps_spin),
                 ("Exposure:", self.exposure_spin), ("Gain:", self.gain_spin),
                 ("Focus:", forms.row(self.focus_spin, self.autofocus_check, stretch=False)),
                 ("White balance:", self.wb_spin))
        for i, (label, item) in enumerate(cells):
            r, c = divmod(i, 2)          # two columns: the form fits a small screen beside the explain panel
            grid.addWidget(QLabel(label), r, 2 * c)
            if isinstance(item, QWidget):
                grid.addWidget(item, r, 2 * c + 1)
            else:
                grid.addLayout(item, r, 2 * c + 1)

    def settings(self) -> CameraSettings:
        def value(box):
            return box.value() if box.value() > box.minimum() else None

        width, height = value(self.width_spin), value(self.height_spin)
        autofocus = self.autofocus_check.isChecked()
        return CameraSettings(width=width, height=height, pixel_format=self.format_combo.currentData() or None,
                              fps=value(self.fps_spin), exposure=value(self.exposure_spin),
                              gain=value(self.gain_spin), autofocus=autofocus,
                              focus=None if autofocus else value(self.focus_spin),
                              white_balance=value(self.wb_spin))

    def set_settings(self, s: CameraSettings) -> None:
        for box, v in ((self.width_spin, s.width), (self.height_spin, s.height), (self.fps_spin, s.fps),
                       (self.exposure_spin, s.exposure), (self.gain_spin, s.gain), (self.focus_spin, s.focus),
                       (self.wb_spin, s.white_balance)):
            box.setValue(v if v is not None else box.minimum())
        self.format_combo.setCurrentIndex(max(self.format_combo.findData(s.pixel_format or ""), 0))
        self.autofocus_check.setChecked(s.autofocus)


def actual_table(left, right) -> str:
    """HTML: what each opened camera really uses (`Camera.settings`), then what did not take."""
    def cell(cam, key):
        v = cam.settings.get(key)
        if v is None or (isinstance(v, float) and v < 0):
            return "—"
        return esc(f"{v:g}" if isinstance(v, float) else str(v).strip("\0") or "—")

    rows = "".join(f"<tr><td>{esc(k)}</td><td align='right'>{cell(left, k)}</td><td align='right'>"
                   f"{cell(right, k)}</td></tr>" for k in SHOWN if k in left.settings or k in right.settings)
    html = ("<table cellspacing='0' cellpadding='2'><tr><th align='left'>actual</th><th>left</th><th>right</th></tr>"
            + rows + "</table>") if rows else ""
    warnings = left.warnings + right.warnings
    if warnings:
        html += ("<b style='color:#c5221f'>⚠ Settings that did not take:</b><br>"
                 + "<br>".join(esc(w) for w in warnings))
    return html
