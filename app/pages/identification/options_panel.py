"""The identification's options: validation (hold-out or k-fold), robust Huber weights, a prior
toward nominal, the measured marker orientations, the arm's deflection under its weight and the
payload mounted while measuring, the parameters kept at nominal; the Identify button and the
progress row."""
from __future__ import annotations

from typing import Callable

from PySide6.QtWidgets import (QCheckBox, QComboBox, QGroupBox, QHBoxLayout, QLabel, QLineEdit, QMenu,
                               QToolButton, QVBoxLayout)

from app.pages.forms import button, double_spin, spin
from app.pages.identification.model import IdentificationOptions
from core.errors import RoboCalError
from core.kinematics.jacobian import all_parameters, resolve_names
from core.identification.prior import PriorOptions
from core.robot.compliance import Compliance
from widgets.flow_layout import FlowLayout
from widgets.progress_row import ProgressRow

VALIDATION_NONE, VALIDATION_HOLDOUT, VALIDATION_KFOLD = range(3)
#: the deflection choices as shown, and identify()'s value of each
DEFLECTION_CHOICES = (("Geometry only", "off"), ("Deflection if it helps", "auto"), ("With deflection", "on"))


class OptionsPanel(QGroupBox):
    """`options()` gives identify()'s options (IdentificationOptions) for the robot `robot()`
    returns, `show_options(o)` shows them; `on_identify()` when Identify is clicked."""

    def __init__(self, progress: ProgressRow, *, robot: Callable, on_identify: Callable, parent=None):
        super().__init__("Options", parent)
        self.fix_actions = {}                    # parameter name -> checkable QAction of the Choose menu
        self.validation_combo = QComboBox()
        self.validation_combo.addItems(["No validation", "Hold out poses", "k-fold cross validation"])
        self.validation_combo.setCurrentIndex(VALIDATION_HOLDOUT)
        self.holdout_spin = spin(25, 5, 50, suffix=" % of the poses")
        self.kfold_spin = spin(5, 2, 20, suffix=" folds")
        self.validation_combo.currentIndexChanged.connect(self._validation_changed)
        self.huber_check = QCheckBox("Robust (Huber), k =")
        self.huber_check.setToolTip("Down-weight points whose error is beyond k robust standard deviations "
                                    "and flag outliers (a marker found in the wrong place).")
        self.huber_spin = double_spin(3.0, 1.0, 10.0, step=0.5)
        self.huber_spin.setEnabled(False)
        self.huber_check.toggled.connect(self.huber_spin.setEnabled)
        self.prior_check = QCheckBox("Prior toward nominal")
        self.prior_check.setObjectName("priorCheck")
        self.prior_check.setToolTip("Estimate the parameters the poses barely determine with a pull toward their "
                                    "nominal values instead of keeping them at nominal; how strong the pull is "
                                    "(for lengths and for angles) is estimated from the measurements.")
        self.orientation_check = QCheckBox("Use the marker's orientation")
        self.orientation_check.setObjectName("orientationCheck")
        self.orientation_check.setToolTip(
            "Also fit how the marker is turned in every pose (measured from its four corners) and estimate how it "
            "sits on the flange (marker.rx, .ry, .rz). Fix marker.rz when the marker's turn about the last axis "
            "is known: the last joint's zero is then determined even with the marker on that axis.")
        self.orientation_check.toggled.connect(lambda _: self.rebuild_fix_menu())
        self.deflection_combo = QComboBox()
        self.deflection_combo.setObjectName("deflectionCombo")
        self.deflection_combo.addItems([label for label, _ in DEFLECTION_CHOICES])
        self.deflection_combo.setToolTip(
            "An industrial arm bends a little under its own weight and its payload: the shoulder and elbow stand "
            "at slightly other angles than their encoders say. 'Deflection if it helps' adds six terms that follow "
            "the weight's torque and keeps them only when they predict poses left out of the fit better; "
            "'With deflection' always keeps them. For a vertical arm (shoulder and elbow horizontal) only.")
        self.deflection_combo.currentIndexChanged.connect(lambda _: self.rebuild_fix_menu())
        self.payload_check = QCheckBox("Payload")
        self.payload_check.setObjectName("payloadCheck")
        self.payload_check.setToolTip("The mass mounted on the flange while the poses were measured; it is kept "
                                      "with the calibration, whose deflection terms hold for this payload.")
        self.payload_spin = double_spin(0.0, 0.0, 5000.0, step=0.5, suffix=" kg")
        self.payload_spin.setObjectName("payloadSpin")
        self.payload_spin.setEnabled(False)
        self.payload_check.toggled.connect(self.payload_spin.setEnabled)
        self.fix_edit = QLineEdit()
        self.fix_edit.setObjectName("fixEdit")
        self.fix_edit.setPlaceholderText("parameters kept at nominal, e.g. J6.d, marker.z")
        self.fix_button = QToolButton()
        self.fix_button.setText("Choose ▾")
        self.fix_button.setPopupMode(QToolButton.ToolButtonPopupMode.InstantPopup)
        self.fix_menu = QMenu(self)
        self.fix_button.setMenu(self.fix_menu)
        self.run_button = button("Identify", "identifyButton", on_click=on_identify)
        self.run_button.setDefault(True)
        self.progress = progress
        self._robot = robot

        # the option rows wrap on a narrow window instead of widening it or cutting the words short
        validation = FlowLayout()
        validation.add_group(QLabel("Validation:"), self.validation_combo, self.holdout_spin, self.kfold_spin)
        validation.add_group(self.huber_check, self.huber_spin)
        validation.addWidget(self.prior_check)
        validation.addWidget(self.orientation_check)
        validation.add_group(QLabel("Deflection:"), self.deflection_combo)
        validation.add_group(self.payload_check, self.payload_spin)
        fix = QHBoxLayout()
        fix.addWidget(QLabel("Fix:"))
        fix.addWidget(self.fix_edit, 1)
        fix.addWidget(self.fix_button)
        fix.addWidget(self.run_button)
        layout = QVBoxLayout(self)
        layout.addLayout(validation)
        layout.addLayout(fix)
        layout.addWidget(progress)
        self.fix_edit.textEdited.connect(self._sync_fix_menu)
        self._validation_changed()

    def options(self) -> IdentificationOptions:
        """identify()'s options chosen here (raises RoboCalError for unknown parameter names)."""
        mode = self.validation_combo.currentIndex()
        return IdentificationOptions(
            huber=float(self.huber_spin.value()) if self.huber_check.isChecked() else None,
            holdout=self.holdout_spin.value() / 100.0 if mode == VALIDATION_HOLDOUT else None,
            kfold=self.kfold_spin.value() if mode == VALIDATION_KFOLD else None,
            fixed=tuple(self.fixed_names()),
            prior=PriorOptions() if self.prior_check.isChecked() else None,
            orientation=self.orientation_check.isChecked(),
            compliance=self.compliance(),
            payload_kg=float(self.payload_spin.value()) if self.payload_check.isChecked() else None)

    def show_options(self, o: IdentificationOptions) -> None:
        """Show `o` (the spin boxes of what is off keep their values)."""
        mode = VALIDATION_KFOLD if o.kfold is not None else VALIDATION_HOLDOUT if o.holdout is not None \
            else VALIDATION_NONE
        self.validation_combo.setCurrentIndex(mode)
        if o.holdout is not None:
            self.holdout_spin.setValue(round(o.holdout * 100))
        if o.kfold is not None:
            self.kfold_spin.setValue(o.kfold)
        self.huber_check.setChecked(o.huber is not None)
        if o.huber is not None:
            self.huber_spin.setValue(o.huber)
        self.prior_check.setChecked(o.prior is not None)
        self.orientation_check.setChecked(o.orientation)
        self.deflection_combo.setCurrentIndex([value for _, value in DEFLECTION_CHOICES].index(o.compliance))
        self.payload_check.setChecked(o.payload_kg is not None)
        if o.payload_kg is not None:
            self.payload_spin.setValue(o.payload_kg)
        self.fix_edit.setText(", ".join(o.fixed))
        self._sync_fix_menu()

    def compliance(self) -> str:
        """identify()'s deflection choice: "off", "auto" or "on"."""
        return DEFLECTION_CHOICES[self.deflection_combo.currentIndex()][1]

    def fixed_names(self) -> list[str]:
        """The canonical names of the parameters typed in the Fix field (RoboCalError if unknown)."""
        raw = [t for t in self.fix_edit.text().replace(";", ",").replace(" ", ",").split(",") if t.strip()]
        if not raw:
            return []
        robot = self._robot()
        return resolve_names(raw, self._parameters(robot), robot)

    def _parameters(self, robot) -> list:
        """Every parameter of `robot`, with the targets' orientations and the deflection terms when they
        are used."""
        targets = list(robot.targets)
        if self.compliance() != "off" and robot.compliance is None:
            robot = robot.copy()
            robot.compliance = Compliance.zero(robot.dof)
        return all_parameters(robot, targets, targets if self.orientation_check.isChecked() else (),
                              compliance=self.compliance() != "off")

    def set_busy(self, busy: bool) -> None:
        for w in (self.validation_combo, self.holdout_spin, self.kfold_spin, self.huber_check, self.prior_check,
                  self.orientation_check, self.deflection_combo, self.payload_check, self.fix_edit, self.fix_button):
            w.setEnabled(not busy)
        self.huber_spin.setEnabled(not busy and self.huber_check.isChecked())
        self.payload_spin.setEnabled(not busy and self.payload_check.isChecked())
        self.progress.bar.setVisible(busy)
        self.progress.reset()

    def _validation_changed(self, *_):
        mode = self.validation_combo.currentIndex()
        self.holdout_spin.setVisible(mode == VALIDATION_HOLDOUT)
        self.kfold_spin.setVisible(mode == VALIDATION_KFOLD)

    def rebuild_fix_menu(self) -> None:
        """The Choose menu: every parameter of the robot, grouped by joint (empty without one)."""
        robot = self._robot()
        self.fix_menu.clear()
        self.fix_actions.clear()
        if robot is None:
            return
        try:
            params = self._parameters(robot)
        except RoboCalError:
            return
        groups: dict[str, list] = {}
        for p in params:
            groups.setdefault(p.name.split(".")[0], []).append(p)
        for group, members in groups.items():
            sub = self.fix_menu.addMenu(group)
            for p in members:
                action = sub.addAction(p.name)
                action.setCheckable(True)
                action.toggled.connect(self._fix_toggled)
                self.fix_actions[p.name] = action
        self._sync_fix_menu()

    def _fix_toggled(self, *_):
        self.fix_edit.setText(", ".join(n for n, a in self.fix_actions.items() if a.isChecked()))

    def _sync_fix_menu(self, *_):
        try:
            names = set(self.fixed_names())
        except RoboCalError:
            return
        for name, action in self.fix_actions.items():
            action.blockSignals(True)
            action.setChecked(name in names)
            action.blockSignals(False)
