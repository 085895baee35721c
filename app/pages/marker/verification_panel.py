"""The Marker page's Verification tab: the marker located at N random robot poses of the
virtual lab, its detection rate, 3D errors against the truth (mm), the predicted σ (image
noise, and with the stereo calibration's uncertainty) explained, and rejection reasons."""
from __future__ import annotations

import math

import numpy as np
from PySide6.QtCore import Qt, Signal
from PySide6.QtWidgets import QHBoxLayout, QLabel, QVBoxLayout, QWidget

from app.html import esc, number
from app.jobs.marker import VerificationResult
from app.pages.forms import button, row, scrolling, spin
from app.pages.marker.model import VerificationOptions
from widgets.precision_plot import PrecisionPlot
from widgets.progress_row import ProgressRow

IDLE_TEXT = ("<span style='color:#5f6368'>The robot visits N random poses where both cameras see the marker; "
             "each pair is located and compared with the virtual lab's true marker position.</span>")


def verification_html(v: VerificationResult, truth: bool = True) -> str:
    """Detection rate, 3D errors (mm), the predicted σ (image noise, and with the stereo
    calibration's uncertainty when known) with where they differ, and the rejection reasons."""
    rate = f"<b>{v.n_located} of {v.n}</b> located ({100 * v.detection_rate:.0f} %)"
    if v.cancelled_after is not None:
        rate += f" — cancelled after {v.n} of {v.poses_planned} poses (those measured are kept)"
    elif v.n < v.poses_planned:
        rate += f" so far — pose {v.n} of {v.poses_planned}"
    rows = [f"<p>{rate} in {v.seconds:.1f} s.</p>"]
    known = math.isfinite(v.median_total_sigma)
    if truth and v.n_located:
        total = (f"<tr><td>σ with the stereo calibration&nbsp;</td><td align='right'>"
                 f"<b>{number(v.median_total_sigma, 3, 'mm')}</b></td></tr>") if known else ""
        rows.append("<table cellspacing='0' cellpadding='2'>"
                    f"<tr><td>median 3D error&nbsp;</td><td align='right'><b>{number(v.median_error, 3, 'mm')}</b>"
                    "</td></tr>"
                    f"<tr><td>RMS 3D error</td><td align='right'><b>{number(v.rms_error, 3, 'mm')}</b></td></tr>"
                    f"<tr><td>largest error</td><td align='right'>{number(v.max_error, 3, 'mm')}</td></tr>"
                    f"<tr><td>median σ, image noise&nbsp;</td><td align='right'>{number(v.median_sigma, 3, 'mm')}"
                    f"</td></tr>{total}</table>")
        rows.append(f"<p style='color:#5f6368'>{sigma_explanation(v)}</p>")
    if v.reasons:
        rows.append("<p><b>Rejected</b> (a clear reason, never a guessed point):</p><ul>"
                    + "".join(f"<li>{n}× {esc(r)}</li>" for r, n in v.reasons.most_common()) + "</ul>")
    elif v.n_located == v.n:
        rows.append("<p>No pose rejected.</p>")
    rows.append(f"<p style='color:#5f6368'>Stereo: {esc(v.stereo)}. Errors are against the virtual lab's "
                "true marker positions.</p>")
    return "".join(rows)


def sigma_explanation(v: VerificationResult) -> str:
    """In plain words, with the numbers: why the error can exceed the image-noise σ."""
    text = (f"The σ of each point ({number(v.median_sigma, 3, 'mm')}, median) is the image noise carried "
            "through triangulation: how much the point scatters from one pair of images to the next with "
            "the stereo calibration taken as exact. The calibration's own error is not in it: its focal "
            "lengths, principal points and the rotation and offset between the cameras are estimates, and "
            "their error is one systematic error shared by every point measured with it.")
    if math.isfinite(v.median_total_sigma):
        text += (f" Carried through triangulation from the calibration's parameter uncertainty it is "
                 f"{number(v.median_calibration_sigma, 3, 'mm')} (median); with the image noise, "
                 f"σ = {number(v.median_total_sigma, 3, 'mm')}, to compare with the median error of "
                 f"{number(v.median_error, 3, 'mm')}.")
    else:
        text += (" The uncertainty of this calibration's parameters is not known here (the virtual lab's true "
                 "cameras, or a calibration made elsewhere without it), so only the image noise is predicted.")
    return text


class VerificationPanel(QWidget):
    """The Verification tab with the page's progress row; the page connects `verify_button`
    and calls `draw(result)`. `pointsArrived(result so far)` may be emitted from a worker thread
    (Qt queues it to the GUI thread); the page draws it while its verification runs.
    `options()` the poses chosen (`optionsChanged()` on a change), `show_options(o)` binds back."""

    pointsArrived = Signal(object)
    optionsChanged = Signal()

    def __init__(self, progress: ProgressRow, parent: QWidget | None = None):
        super().__init__(parent)
        self.progress = progress
        self.verify_spin = spin(VerificationOptions().poses, 1, 500, name="verifySpin",
                                tooltip="Random robot poses where both cameras see the marker")
        self.verify_spin.valueChanged.connect(lambda *_: self.optionsChanged.emit())
        self.verify_button = button("Run verification", "verifyButton")
        self.verify_summary = QLabel()
        self.verify_summary.setObjectName("verifySummary")
        self.verify_summary.setWordWrap(True)
        self.verify_summary.setTextFormat(Qt.TextFormat.RichText)
        self.verify_summary.setAlignment(Qt.AlignmentFlag.AlignTop | Qt.AlignmentFlag.AlignLeft)
        self.verify_summary.setMinimumWidth(230)
        self.verify_summary.setMaximumWidth(320)
        self.precision_plot = PrecisionPlot()
        layout = QVBoxLayout(self)
        layout.setContentsMargins(4, 4, 4, 4)
        controls = row("Poses:", self.verify_spin, self.verify_button, stretch=False)
        controls.addWidget(progress, 1)
        layout.addLayout(controls)
        body = QHBoxLayout()
        body.addWidget(scrolling(self.verify_summary))
        body.addWidget(self.precision_plot, 1)
        layout.addLayout(body, 1)

    def options(self) -> VerificationOptions:
        return VerificationOptions(self.verify_spin.value())

    def show_options(self, options: VerificationOptions) -> None:
        self.verify_spin.setValue(options.poses)

    def draw(self, v: VerificationResult | None, running: bool = False) -> None:
        """The summary and the precision plot of `v` (None: what a verification does); `running`:
        the poses measured so far (the progress row goes on)."""
        if v is None:
            self.verify_summary.setText(IDLE_TEXT)
            self.precision_plot.clear_points()
            self.progress.reset()
            return
        self.verify_summary.setText(verification_html(v))
        total = np.hypot(v.sigmas, v.calibration_sigmas) if v.calibration_sigmas is not None else None
        self.precision_plot.set_points(v.depth, v.errors, v.sigmas, total)
        if running:
            return
        if v.cancelled_after is not None:
            self.progress.set_progress(v.n / v.poses_planned, f"cancelled after {v.n} of {v.poses_planned} poses")
        else:
            self.progress.set_progress(1.0, "done")
