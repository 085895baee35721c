"""The Export page's folder box: where the exports go, Choose folder… and Export all."""
from __future__ import annotations

from pathlib import Path

from PySide6.QtWidgets import QFileDialog, QGroupBox, QHBoxLayout, QLineEdit

from app.pages import forms
from app.pages.export.model import ExportOptions


class FolderBox(QGroupBox):
    """The buttons' clicks are the page's to connect (folder_button, all_button)."""

    def __init__(self, parent=None):
        super().__init__("Export folder", parent)
        self.folder_edit = QLineEdit()
        self.folder_edit.setObjectName("exportFolder")
        self.folder_edit.setReadOnly(True)
        self.folder_button = forms.button("Choose folder…")
        self.all_button = forms.button("Export all", "exportAllButton")
        self.all_button.setDefault(True)
        layout = QHBoxLayout(self)
        layout.addWidget(self.folder_edit, 1)
        layout.addWidget(self.folder_button)
        layout.addWidget(self.all_button)

    def ask_folder(self, start: Path) -> ExportOptions | None:
        """The folder chosen in a dialog opened at `start` (None: cancelled)."""
        chosen = QFileDialog.getExistingDirectory(self, "Export folder", str(start))
        return ExportOptions(Path(chosen)) if chosen else None

    def show_folder(self, folder: Path | None) -> None:
        self.folder_edit.setText(str(folder) if folder else "")
