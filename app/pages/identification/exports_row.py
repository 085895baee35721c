"""The row under the Identification page's results: save calibrated.json into the project, or
export the calibrated model as a DH table (CSV) or a URDF, to a file asked for here."""
from __future__ import annotations

from pathlib import Path

from PySide6.QtWidgets import QFileDialog, QHBoxLayout, QLabel, QWidget

from app.pages.forms import button

#: per export format: the dialog's title, the default file name and the file filter
EXPORTS = {"urdf": ("Export the calibrated URDF", "calibrated.urdf", "URDF (*.urdf);;All files (*)"),
           "dh-csv": ("Export the calibrated DH table", "calibrated_dh.csv", "CSV table (*.csv);;All files (*)")}


class ExportsRow(QWidget):
    """The buttons' clicks are the page's to connect (save_button, csv_button, urdf_button)."""

    def __init__(self, parent=None):
        super().__init__(parent)
        self.save_button = button("Save calibrated.json",
                                  tooltip="Write the calibrated robot model (with its calibration section) into "
                                          "the project folder")
        self.csv_button = button("Export DH table (CSV)…")
        self.urdf_button = button("Export URDF…")
        layout = QHBoxLayout(self)
        layout.setContentsMargins(0, 0, 0, 0)
        layout.addWidget(QLabel("Calibrated model:"))
        layout.addStretch(1)
        for b in (self.save_button, self.csv_button, self.urdf_button):
            layout.addWidget(b)

    def set_enabled(self, has_result: bool) -> None:
        for b in (self.save_button, self.csv_button, self.urdf_button):
            b.setEnabled(has_result)

    def ask_path(self, fmt: str, folder: Path) -> str | None:
        """The file to export `fmt` ("dh-csv" or "urdf") to, asked in `folder` (None: not chosen)."""
        title, name, filt = EXPORTS["urdf" if fmt == "urdf" else "dh-csv"]
        chosen, _ = QFileDialog.getSaveFileName(self, title, str(folder / name), filt)
        return chosen or None
