"""The Setup page's Project box: the project folder and its details, New, Open and Change cell."""
from __future__ import annotations

from PySide6.QtCore import Qt
from PySide6.QtWidgets import QGroupBox, QHBoxLayout, QLabel, QVBoxLayout

from app.pages import forms
from app.pages.setup.model import SetupView


class ProjectBox(QGroupBox):
    """The buttons' clicks are the page's to connect (new_button, open_button, cell_button)."""

    def __init__(self, parent=None):
        super().__init__("Project", parent)
        self.project_folder = QLabel()
        self.project_folder.setTextInteractionFlags(Qt.TextInteractionFlag.TextSelectableByMouse)
        self.project_folder.setWordWrap(True)
        self.project_details = QLabel()
        self.project_details.setObjectName("hint")
        self.project_details.setWordWrap(True)
        self.new_button = forms.button("New project…")
        self.open_button = forms.button("Open project…")
        self.cell_button = forms.button("Change cell…", "changeCellButton",
                                        tooltip="Measure on the virtual lab, or on a real cell: its robot "
                                                "connection and cameras")
        row = QHBoxLayout(self)
        text_col = QVBoxLayout()
        text_col.addWidget(self.project_folder)
        text_col.addWidget(self.project_details)
        row.addLayout(text_col, 1)
        row.addWidget(self.new_button)
        row.addWidget(self.open_button)
        row.addWidget(self.cell_button)

    def show_view(self, view: SetupView) -> None:
        self.project_folder.setText(view.project_title)
        self.project_details.setText(view.project_details)
        self.cell_button.setEnabled(view.has_project)
