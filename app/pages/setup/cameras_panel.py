"""The Setup page's cameras: the virtual lab's two cameras, or two sources (each a device
index, a device path, a video file or an image folder), opened on the worker and previewed
side by side (app.preview: a worker grabs, the GUI shows the newest pair, frames it has no
time for are dropped)."""
from __future__ import annotations

from PySide6.QtWidgets import (QButtonGroup, QFileDialog, QGridLayout, QGroupBox, QLabel, QLineEdit, QRadioButton,
                               QVBoxLayout, QWidget)

from app.hardware import SOURCES, CameraChoice, LiveCameras
from app.html import esc
from app.pages import forms
from app.pages.setup.camera_settings import CameraSettingsForm, actual_table
from app.preview import PreviewPump
from core.measurement.capture import CameraSettings
from widgets.stereo_preview import StereoPreview


def open_cameras(choice: CameraChoice, settings: CameraSettings | None = None) -> LiveCameras:
    """Open both sources with `settings` (worker thread: a camera may take a second to start)."""
    return LiveCameras.open(choice, settings)


class CameraPanel(QGroupBox):
    """`page`: the Setup page (its state, `start` and status line)."""

    def __init__(self, page, parent: QWidget | None = None):
        super().__init__("Cameras", parent)
        self.page = page
        self.state = page.state
        self.pump: PreviewPump | None = None

        self.virtual_radio = QRadioButton("Virtual lab cameras (simulated stereo pair)")
        self.virtual_radio.setObjectName("virtualCamerasRadio")
        self.sources_radio = QRadioButton("Cameras or recordings")
        self.sources_radio.setObjectName("sourceCamerasRadio")
        group = QButtonGroup(self)
        group.addButton(self.virtual_radio)
        group.addButton(self.sources_radio)
        self.virtual_radio.setChecked(True)
        self.virtual_radio.toggled.connect(self._kind_toggled)

        self.left_edit, self.right_edit = QLineEdit(), QLineEdit()
        grid = QGridLayout()
        grid.setContentsMargins(18, 0, 0, 0)
        for r, (side, edit) in enumerate((("Left", self.left_edit), ("Right", self.right_edit))):
            edit.setObjectName(f"{side.lower()}CameraEdit")
            edit.setPlaceholderText("device index (0), /dev/video2, a video file or an image folder")
            grid.addWidget(QLabel(f"{side}:"), r, 0)
            grid.addWidget(edit, r, 1)
            grid.addWidget(forms.button("File…", on_click=lambda e=edit: self._browse(e, folder=False)), r, 2)
            grid.addWidget(forms.button("Folder…", on_click=lambda e=edit: self._browse(e, folder=True)), r, 3)
        self.settings_form = CameraSettingsForm()
        grid.addWidget(self.settings_form, 2, 1, 1, 3)
        self.open_button = forms.button("Open cameras", "openCamerasButton", on_click=self.open_cameras)
        self.preview_button = forms.button("Stop preview", "previewButton", on_click=self.toggle_preview)
        grid.addLayout(forms.row(self.open_button, self.preview_button), 3, 1, 1, 3)
        self.sources_form = QWidget()
        self.sources_form.setLayout(grid)

        self.preview = StereoPreview()
        self.status_label = QLabel()
        self.status_label.setObjectName("hint")
        self.status_label.setWordWrap(True)

        layout = QVBoxLayout(self)
        layout.addWidget(self.virtual_radio)
        layout.addWidget(self.sources_radio)
        layout.addWidget(self.sources_form)
        layout.addWidget(self.preview, 1)
        layout.addWidget(self.status_label)
        self.state.hardware.camerasChanged.connect(self._cameras_changed)
        self.state.projectChanged.connect(self.restore)
        self.refresh()

    def choice(self) -> CameraChoice:
        return CameraChoice(SOURCES, self.left_edit.text().strip(), self.right_edit.text().strip())

    def restore(self, project) -> None:
        """Fill the fields with the cameras the project recorded (opened with Open cameras)."""
        saved = project.cameras if project is not None else None
        if saved is None or saved.kind != SOURCES:
            return
        self.left_edit.setText(saved.left or "")
        self.right_edit.setText(saved.right or "")
        try:
            self.settings_form.set_settings(CameraSettings(**(saved.settings or {})))
        except TypeError:                       # settings of another version: the form's defaults
            pass
        self.sources_radio.setChecked(True)

    def _browse(self, edit: QLineEdit, folder: bool) -> None:
        if folder:
            path = QFileDialog.getExistingDirectory(self, "Image folder")
        else:
            path, _ = QFileDialog.getOpenFileName(self, "Video file", "", "Videos (*.avi *.mp4 *.mkv *.mov);;"
                                                                          "All files (*)")
        if path:
            edit.setText(path)

    def _kind_toggled(self, virtual: bool) -> None:
        if virtual and self.state.hardware.cameras is not None:
            self.state.hardware.set_cameras(None)
        self.refresh()

    # -- actions (tests call them) -------------------------------------------------------
    def open_cameras(self) -> bool:
        self.sources_radio.setChecked(True)
        choice = self.choice()
        self.stop_preview()
        return self.page.task.start(open_cameras, choice, self.settings_form.settings(), on_done=lambda cams: self.state.hardware.set_cameras(cams, choice),
                               label="Opening the cameras", status="Opening the cameras…")

    def start_preview(self) -> None:
        cams = self.state.hardware.cameras
        if cams is None or (self.pump is not None and self.pump.running):
            return
        self.pump = PreviewPump(cams, self)
        self.pump.framesReady.connect(self._frames)
        self.pump.failed.connect(self._preview_failed)
        self.pump.start()
        self.refresh()

    def stop_preview(self) -> None:
        if self.pump is not None:
            self.pump.stop()
            self.pump.deleteLater()
            self.pump = None
        self.refresh()

    def toggle_preview(self) -> None:
        if self.pump is not None and self.pump.running:
            self.stop_preview()
        else:
            self.start_preview()

    # -- display -------------------------------------------------------------------------
    def _cameras_changed(self, cams) -> None:
        self.stop_preview()
        self.preview.clear()
        if cams is not None and self.state.hardware.camera_changes:
            self.page._set_status("⚠ Not the cameras this project used: " + "; ".join(self.state.hardware.camera_changes)
                                  + ". Check the cables (left and right) before capturing.", False)
        elif cams is not None:
            self.page._set_status("✓ Cameras open.", True)
            if self.isVisible():
                self.start_preview()
        self.refresh()

    def _frames(self, left, right) -> None:
        self.preview.show_pair(left, right)
        if self.pump is not None and self.pump.shown % 10 == 0:
            self.preview.set_caption(f"Preview: {self.pump.fps():.1f} frames/s")

    def _preview_failed(self, message: str) -> None:
        self.stop_preview()
        self.page._set_status(f"The preview stopped: {message}", False)

    def refresh(self, *_) -> None:
        cams = self.state.hardware.cameras
        sources = self.sources_radio.isChecked()
        self.sources_form.setEnabled(sources)
        self.open_button.setEnabled(sources and not self.page.task.busy)
        running = self.pump is not None and self.pump.running
        self.preview_button.setEnabled(cams is not None)
        self.preview_button.setText("Stop preview" if running else "Start preview")
        self.preview.setVisible(sources)
        if not sources:
            self.status_label.setText("Two simulated cameras with parallel optical axes look at the robot; the "
                                      "marker is rendered where the robot puts it.")
        elif cams is None:
            self.status_label.setText("Give the left and right camera, then Open cameras. Auto focus is switched "
                                      "off and the MJPG format asked for, so both cameras fit on the USB bus.")
        else:
            changed = "".join(f"<br><b style='color:#c5221f'>⚠ {esc(c)}</b>" for c in self.state.hardware.camera_changes)
            self.status_label.setText(esc(cams.describe()) + changed + "<br>"
                                      + actual_table(cams.source.left, cams.source.right))
