"""A folder dialog that takes a new folder's name as well as an existing folder (New project,
Save the demo as a project). Qt's own folder dialog refuses a name that does not exist yet
("Directory not found"); this one accepts it and leaves the folder to be created by whoever
asked (core.project.create_project creates it)."""
from __future__ import annotations

from pathlib import Path

from PySide6.QtWidgets import QDialogButtonBox, QFileDialog, QLineEdit, QWidget


class NewFolderDialog(QFileDialog):
    """Qt's non-native folder dialog in which the name typed may be a folder that does not exist
    yet; `folder()` is the folder chosen (absolute), or None before it is accepted."""

    def __init__(self, parent: QWidget | None, title: str, start: str | Path):
        super().__init__(parent, title, str(start))
        self.setObjectName("newFolderDialog")
        self.setOption(QFileDialog.Option.DontUseNativeDialog, True)
        self.setOption(QFileDialog.Option.ShowDirsOnly, True)
        self.setFileMode(QFileDialog.FileMode.Directory)
        self.setAcceptMode(QFileDialog.AcceptMode.AcceptOpen)
        self.setLabelText(QFileDialog.DialogLabel.FileName, "Folder:")
        self.setLabelText(QFileDialog.DialogLabel.Accept, "Choose")
        self._folder: Path | None = None
        # Qt disables its accept button for a name that does not exist: enabled again after Qt's own update
        self.name_edit = self.findChild(QLineEdit, "fileNameEdit")
        self.name_edit.textChanged.connect(self._allow_new_name)
        self.directoryEntered.connect(self._allow_new_name)

    def accept_button(self):
        return self.findChild(QDialogButtonBox, "buttonBox").button(QDialogButtonBox.StandardButton.Open)

    def _allow_new_name(self, *_) -> None:
        text = self.name_edit.text().strip()
        if text and not Path(self.directory().absoluteFilePath(text)).exists():
            self.accept_button().setEnabled(True)

    def folder(self) -> Path | None:
        return self._folder

    def accept(self) -> None:
        """An existing folder as Qt accepts it; a name that does not exist yet, accepted as it is."""
        selected = self.selectedFiles()
        path = Path(selected[0]) if selected else None
        if path is not None and not path.exists():
            self._folder = path
            self.done(QFileDialog.DialogCode.Accepted)
            return
        super().accept()
        if self.result() == QFileDialog.DialogCode.Accepted and path is not None:
            self._folder = path


def ask_new_folder(parent: QWidget | None, title: str, start: str | Path | None = None) -> Path | None:
    """The folder the user chose or typed (it may not exist yet), None when cancelled."""
    dialog = NewFolderDialog(parent, title, start or Path.home())
    try:
        return dialog.folder() if dialog.exec() == QFileDialog.DialogCode.Accepted else None
    finally:
        dialog.deleteLater()
