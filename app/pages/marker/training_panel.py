"""The Marker page's Training tab, and its row of controls above the tabs: the training image
with the automatically found outer square (dashed), the crop rectangle the user drags, and what
training found (SIFT keypoints, fitted outline, reference point)."""
from __future__ import annotations

import numpy as np
from PySide6.QtCore import Qt, Signal
from PySide6.QtWidgets import QCheckBox, QHBoxLayout, QLabel, QWidget

from app.html import esc
from app.jobs.marker import TrainingImage, auto_outline, crop_around
from app.pages.forms import button, double_spin
from app.pages.marker.model import MarkerResult, TrainingOptions
from app.pages.measurement_inputs import TRAINING_FILE
from core.marker.training import TrainedMarker
from widgets.flow_layout import FlowLayout
from widgets.marker_views import TrainingImageView

UNTRAINED_HELP = ("<b>Training</b><br>The outer black square (dashed orange) is found automatically. If the image "
                  "shows other dark shapes, tick <i>Crop to rectangle</i> and drag the blue rectangle around the "
                  "marker. Give the side of the outer square in mm, then <b>Train</b>.")


def trained_html(t: TrainedMarker, offset: np.ndarray, saved_name: str = "") -> str:
    """What training found, for the panel's side text (px in the shown image, mm on the marker)."""
    x, y = t.reference_px + offset
    return (f"<b>Trained marker</b><ul style='margin-left:-20px'>"
            f"<li><b>{t.n_image_features}</b> SIFT keypoints on the marker (green circles), "
            f"<b>{t.n_features}</b> with those of {len(set(t.keypoint_view.tolist())) - 1} simulated tilted views "
            f"(45° and 60°) that help at oblique angles</li>"
            f"<li>outer square {t.outer_size:.2f} mm, {t.px_per_mm:.2f} px/mm in this image; fitted to "
            f"σ ≈ {t.outline_sigma_px:.3f} px (green)</li>"
            f"<li>reference point (red): the intersection of the diagonals, ({x:.2f}, {y:.2f}) px</li>"
            f"<li>contrast: dark {t.dark_level:.0f}, bright {t.bright_level:.0f} grey levels</li></ul>"
            + (f"Saved: {esc(saved_name)}, {TRAINING_FILE}." if saved_name else ""))


class TrainingPanel(QWidget):
    """The Training tab. `controls` is the row above the tabs (load, capture, crop, outer
    square, Train); the page connects its buttons. `image` is the shown training image;
    `options()` the outer square and crop chosen, `show_options(o)` binds them back.

    Signals: `statusChanged(text, ok)` (ok True, False or None) for the page's status line;
    `optionsChanged()` when what `options()` returns may have changed.
    """

    statusChanged = Signal(str, object)
    optionsChanged = Signal()

    def __init__(self, parent: QWidget | None = None):
        super().__init__(parent)
        self.image: TrainingImage | None = None
        self.load_button = button("Load image…", "loadButton",
                                  tooltip="A sharp image of the marker: its black outer square on a bright plate")
        self.capture_button = button("Capture (virtual lab)", "captureButton",
                                     tooltip="A frontal image of the marker plate with the virtual lab's camera")
        self.crop_check = QCheckBox("Crop to rectangle")
        self.crop_check.setObjectName("cropCheck")
        self.crop_check.setToolTip("Drag the blue rectangle around the marker: only what is inside is trained "
                                   "(for an image with other dark squares or clutter)")
        self.crop_check.toggled.connect(self._crop_toggled)
        self.size_spin = double_spin(TrainingOptions().outer_size, 1.0, 1000.0, decimals=2, step=1.0, name="sizeSpin",
                                     suffix=" mm",
                                     tooltip="Side of the marker's outer black square, measured on the real marker")
        self.size_spin.valueChanged.connect(lambda *_: self.optionsChanged.emit())
        self.train_button = button("Train", "trainButton")
        self.controls = FlowLayout()          # wraps on a narrow window
        for w in (self.load_button, self.capture_button, self.crop_check):
            self.controls.addWidget(w)
        self.controls.add_group(QLabel("Outer square:"), self.size_spin)
        self.controls.addWidget(self.train_button)

        self.training_view = TrainingImageView()
        self.training_view.setObjectName("trainingView")
        self.training_view.cropChanged.connect(self._crop_changed)
        self.training_info = QLabel()
        self.training_info.setObjectName("trainingInfo")
        self.training_info.setWordWrap(True)
        self.training_info.setTextFormat(Qt.TextFormat.RichText)
        self.training_info.setAlignment(Qt.AlignmentFlag.AlignTop | Qt.AlignmentFlag.AlignLeft)
        self.training_info.setMinimumWidth(220)
        self.training_info.setMaximumWidth(300)
        layout = QHBoxLayout(self)
        layout.setContentsMargins(4, 4, 4, 4)
        layout.addWidget(self.training_view, 1)
        layout.addWidget(self.training_info)

    def set_source(self, cameras: bool) -> None:
        """Capture from the cameras opened on the Setup page (True) or the virtual lab's."""
        if cameras:
            self.capture_button.setText("Capture (left camera)")
            self.capture_button.setToolTip("Hold the marker plate facing the left camera, flat and sharp, then "
                                           "capture")
        else:
            self.capture_button.setText("Capture (virtual lab)")
            self.capture_button.setToolTip("A frontal image of the marker plate with the virtual lab's camera")

    def options(self) -> TrainingOptions:
        """The outer square's side (mm) and the crop rectangle (x0, y0, x1, y1) px when cropping
        is ticked, else None."""
        crop = self.training_view.crop_box() if self.crop_check.isChecked() else None
        return TrainingOptions(float(self.size_spin.value()), crop)

    def show_options(self, options: TrainingOptions) -> None:
        self.size_spin.setValue(options.outer_size)
        if (options.crop is not None) != self.crop_check.isChecked():
            self.crop_check.setChecked(options.crop is not None)
        if options.crop is not None and options.crop != self.training_view.crop_box():
            self.training_view.set_crop_box(options.crop)
            self._crop_changed(self.training_view.crop_box())

    def clear(self) -> None:
        self.image = None
        self.training_view.set_image(None)
        self.training_view.set_auto_outline(None)
        self.training_view.clear_detection()
        self.training_info.setText("")
        self.optionsChanged.emit()

    def draw_trained(self, result: MarkerResult) -> None:
        """The model's training image with its trained marker (None: the image alone; no
        image: an empty view)."""
        self.image = result.training_image
        self.show_training(result.trained, result.offset, result.saved_path.name if result.saved_path else "")

    def set_image(self, image: TrainingImage) -> None:
        """A new training image, not trained yet: crop off, the crop box around the found outline
        (else the middle half of the image); what was found goes to `statusChanged`."""
        self.image = image
        if image.outer_size:
            self.size_spin.setValue(image.outer_size)
        self.crop_check.blockSignals(True)
        self.crop_check.setChecked(False)
        self.crop_check.blockSignals(False)
        self.training_view.set_crop_visible(False)
        self.show_training()
        h, w = image.image.shape[:2]
        if image.outline is not None:
            self.training_view.set_crop_box(crop_around(image.outline, w, h))
            self.statusChanged.emit(f"Training image {w}x{h} px from {image.source}: the outer square was found "
                                    "(dashed orange). Train, or crop to a rectangle first.", None)
        else:
            self.training_view.set_crop_box((w // 4, h // 4, 3 * w // 4, 3 * h // 4))
            self.statusChanged.emit(f"Training image {w}x{h} px: {image.outline_problem} Drag a crop rectangle "
                                    "around the marker, or load another image.", False)
        self.optionsChanged.emit()

    def show_training(self, trained: TrainedMarker | None = None, offset=(0.0, 0.0), saved_name: str = "") -> None:
        """The image with its found outline; with `trained` (trained on the crop at `offset` px),
        the keypoints, fitted outline and reference point."""
        img, view = self.image, self.training_view
        if img is None:
            self.clear()
            return
        view.set_image(img.image)
        view.set_auto_outline(img.outline)
        if trained is None:
            view.clear_detection()
            self.training_info.setText(UNTRAINED_HELP)
            return
        off = np.asarray(offset, dtype=float)
        own = trained.keypoint_view == 0
        view.set_auto_outline(None)
        view.show_detection(keypoints=None, inliers=trained.keypoint_xy[own] + off, fitted=trained.outline + off,
                            reference=trained.reference_px + off, corners=trained.outline + off)
        self.training_info.setText(trained_html(trained, off, saved_name))

    def _crop_toggled(self, on: bool) -> None:
        self.training_view.set_crop_visible(on)
        self._crop_changed(self.training_view.crop_box())

    def _crop_changed(self, box) -> None:
        """Find the outline again inside the crop (fast: no worker needed)."""
        self.optionsChanged.emit()
        img = self.image
        if img is None:
            return
        if self.crop_check.isChecked() and box is not None:
            x0, y0, x1, y1 = box
            outline, problem = auto_outline(np.ascontiguousarray(img.image[y0:y1, x0:x1]))
            self.training_view.set_auto_outline(None if outline is None else outline + [x0, y0])
            if outline is None:
                self.statusChanged.emit(f"Inside the crop: {problem}", False)
            else:
                self.statusChanged.emit("Inside the crop the outer square was found (dashed orange): Train.", None)
        else:
            self.training_view.set_auto_outline(img.outline)
