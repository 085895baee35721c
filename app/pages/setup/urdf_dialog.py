"""A URDF's chain for the Setup page: the base and tip links chosen among the URDF's links (first
the ones `robocal robot-import` takes by default), the model the importer makes of that chain
shown before it is taken (its joints and notes, or why the chain cannot be imported).

`ask_urdf_chain(parent, path)` gives the imported model (core.robot.urdf_import.UrdfImport) or
None when cancelled; a file that is not a URDF (an unexpanded xacro …) raises RoboCalError."""
from __future__ import annotations

from pathlib import Path

from PySide6.QtCore import Qt
from PySide6.QtWidgets import QComboBox, QDialog, QDialogButtonBox, QFormLayout, QLabel, QVBoxLayout, QWidget

from app.html import esc
from core.errors import RoboCalError
from core.robot.urdf_import import UrdfImport, import_urdf, urdf_links

CHOOSE = "— choose —"


class UrdfDialog(QDialog):
    """Base and tip link combos over the URDF's links; OK only when that chain imports."""

    def __init__(self, path: str | Path, parent: QWidget | None = None):
        super().__init__(parent)
        self.path = Path(path)
        links = urdf_links(self.path)                 # RoboCalError: not a URDF
        self.setWindowTitle(f"RoboCal: robot model from {self.path.name}")
        self.base_combo = self._combo("urdfBaseCombo", links.links, links.base)
        self.tip_combo = self._combo("urdfTipCombo", links.links, links.tip)
        intro = QLabel("The robot model is the chain of joints from the <b>base link</b> (fixed to the floor "
                       "or table) to the <b>tip link</b> (the flange, or the tool carrying the marker). Joints "
                       "after the tip, such as gripper fingers, are left out.")
        intro.setWordWrap(True)
        self.default_note = QLabel(f"Choose the tip link: {esc(links.why)}." if links.why else "")
        self.default_note.setObjectName("hint")
        self.default_note.setWordWrap(True)
        self.preview = QLabel()
        self.preview.setObjectName("urdfPreview")
        self.preview.setWordWrap(True)
        self.preview.setTextFormat(Qt.TextFormat.RichText)
        self.setMinimumWidth(560)                     # wrapped labels get their height at this width
        self.buttons = QDialogButtonBox(QDialogButtonBox.StandardButton.Ok | QDialogButtonBox.StandardButton.Cancel)
        self.buttons.accepted.connect(self.accept)
        self.buttons.rejected.connect(self.reject)
        form = QFormLayout()
        form.addRow("Base link:", self.base_combo)
        form.addRow("Tip link:", self.tip_combo)
        layout = QVBoxLayout(self)
        layout.addWidget(intro)
        layout.addLayout(form)
        layout.addWidget(self.default_note)
        layout.addWidget(self.preview)
        layout.addWidget(self.buttons)
        self._imported: UrdfImport | None = None
        self.base_combo.currentIndexChanged.connect(self._update)
        self.tip_combo.currentIndexChanged.connect(self._update)
        self._update()

    @staticmethod
    def _combo(name: str, links: list[str], chosen: str | None) -> QComboBox:
        combo = QComboBox()
        combo.setObjectName(name)
        combo.addItem(CHOOSE, None)
        for link in links:
            combo.addItem(link, link)
        combo.setCurrentIndex(max(combo.findData(chosen), 0) if chosen else 0)
        return combo

    def imported(self) -> UrdfImport | None:
        """The model of the chosen chain, None while it cannot be imported."""
        return self._imported

    def _update(self, *_) -> None:
        base, tip = self.base_combo.currentData(), self.tip_combo.currentData()
        self._imported = None
        if base is None or tip is None:
            self.preview.setText("Choose the base and the tip link.")
        else:
            try:
                self._imported = import_urdf(self.path, base=base, tip=tip)
            except RoboCalError as exc:
                hint = (exc.hint or "").replace(" with --tip", "").replace(" with --base", "")
                self.preview.setText(f"<span style='color:#c5221f'>{esc(exc.problem)}</span>"
                                     + (f"<br>{esc(hint)}" if hint and "--" not in hint else ""))
            else:
                model = self._imported.model
                text = (f"<b>{model.dof} joints</b>: {esc(', '.join(j.name for j in model.joints))}")
                if self._imported.notes:
                    text += "<ul>" + "".join(f"<li>{esc(n)}</li>" for n in self._imported.notes) + "</ul>"
                self.preview.setText(text)
        self.buttons.button(QDialogButtonBox.StandardButton.Ok).setEnabled(self._imported is not None)


def ask_urdf_chain(parent: QWidget | None, path: str | Path) -> UrdfImport | None:
    """The model of the chain the user chose in the URDF at `path`; None when cancelled."""
    dialog = UrdfDialog(path, parent)
    try:
        return dialog.imported() if dialog.exec() == QDialog.DialogCode.Accepted else None
    finally:
        dialog.deleteLater()
