"""The Stereo page's checkerboard pairs: where pairs come from (folders, virtual lab, cameras),
the board definition, the thumbnails with their verdicts, and the ROS-style coverage bars.
`PairsPanel` shows them and follows the step's model (model.py); the page's PairSources
(pair_sources.py) adds, removes and redetects pairs on the worker thread."""
from __future__ import annotations

from PySide6.QtCore import QSize, Qt
from PySide6.QtWidgets import QFileDialog, QGroupBox, QLabel, QVBoxLayout

from app.html import esc
from app.jobs.stereo import THUMB_WIDTH
from app.pages.forms import button, double_spin, row, spin
from app.pages.stereo.model import StereoModel
from app.pages.stereo.texts import (BAR_TIPS, CAMERA_TOOLTIP_HARDWARE, CAMERA_TOOLTIP_LIVE, CAMERA_TOOLTIP_NO_BOARD,
                                    CAMERA_TOOLTIP_VIRTUAL, VIRTUAL_TOOLTIP, short_reason)
from core.stereo.board import Board
from core.stereo.coverage import MIN_BAR, MIN_GOOD_PAIRS, MIN_PAIRS_TO_CALIBRATE
from widgets.coverage_bars import CoverageBars
from widgets.flow_layout import FlowLayout
from widgets.thumbnail_strip import BAD, MUTED, WARN, ThumbnailStrip

VIRTUAL_PAIRS = 20


class PairsPanel(QGroupBox):
    """Buttons to add and remove pairs, the board (inner corners, square size), the strip
    of thumbnails, the coverage bars and what to do next."""

    def __init__(self, parent=None):
        super().__init__("Checkerboard pairs", parent)
        self.folders_button = button("Add from folders…", "foldersButton",
                                     tooltip="Choose the left camera's folder, then the right camera's; images "
                                             "are paired by sorted file name. One folder of leftNN and rightNN "
                                             "images is paired by name.")
        self.virtual_button = button("Render virtual-lab pairs", "virtualButton")
        self.virtual_count = spin(VIRTUAL_PAIRS, 1, 60, suffix=" pairs")
        self.capture_button = button("Capture from cameras", "captureButton")
        self.remove_button = button("Remove", tooltip="Remove the selected pairs from the calibration "
                                                      "(files stay on disk)")
        self.clear_button = button("Clear", tooltip="Remove every pair from the page (files stay on disk)")
        self.cols_spin = spin(9, 2, 60, tooltip="Inner corners along a row of the board (squares − 1)")
        self.rows_spin = spin(6, 2, 60, tooltip="Inner corners along a column of the board (squares − 1)")
        self.square_spin = double_spin(24.0, 0.1, 1000.0, decimals=2, step=1.0, suffix=" mm",
                                       tooltip="Side of one square, measured on the printed board")
        self.strip = ThumbnailStrip(icon_size=QSize(2 * THUMB_WIDTH + 4, int(THUMB_WIDTH * 0.8)))
        self.count_label = QLabel()
        self.count_label.setObjectName("countLabel")
        self.coverage_bars = CoverageBars(("X", "Y", "size", "skew"), threshold=MIN_BAR, tooltips=BAR_TIPS,
                                          labels={"size": "Size", "skew": "Skew"})
        self.advice = QLabel()
        self.advice.setObjectName("adviceLabel")
        self.advice.setWordWrap(True)

        layout = QVBoxLayout(self)
        layout.setSpacing(4)
        # rows that wrap on a narrow window
        sources = FlowLayout()
        sources.addWidget(self.folders_button)
        sources.add_group(self.virtual_button, self.virtual_count)
        sources.addWidget(self.capture_button)
        layout.addLayout(sources)
        board_row = FlowLayout()
        board_row.add_group(QLabel("Board:"), self.cols_spin, QLabel("×"), self.rows_spin)
        board_row.add_group(QLabel("inner corners, square"), self.square_spin)
        board_row.addWidget(self.remove_button)
        board_row.addWidget(self.clear_button)
        layout.addLayout(board_row)
        layout.addWidget(self.strip)
        cov = row("Coverage:", stretch=False)
        cov.addWidget(self.coverage_bars, 1)
        layout.addLayout(cov)
        advice_row = row(stretch=False)
        advice_row.addWidget(self.count_label, 0, Qt.AlignmentFlag.AlignTop)
        advice_row.addWidget(self.advice, 1)
        layout.addLayout(advice_row)

    # -- the board ------------------------------------------------------------------------
    def board(self) -> Board:
        """The board the spin boxes describe."""
        return Board(self.cols_spin.value(), self.rows_spin.value(), float(self.square_spin.value()))

    def set_board(self, board: Board) -> None:
        """Show `board` without emitting valueChanged."""
        for w, v in ((self.cols_spin, board.cols), (self.rows_spin, board.rows), (self.square_spin, board.square)):
            w.blockSignals(True)
            w.setValue(v)
            w.blockSignals(False)

    def show_controls(self, busy: bool, has_project: bool, virtual: bool, cameras: bool, ready: bool,
                      has_pairs: bool) -> None:
        """Enable what can be done now: nothing while a task runs; the virtual lab only in a
        virtual-lab project; a capture from the `cameras` opened on the Setup page only while a
        pair with the board in both images is `ready` (without them, from the virtual lab)."""
        for w in (self.folders_button, self.cols_spin, self.rows_spin, self.square_spin):
            w.setEnabled(not busy and has_project)
        for w in (self.virtual_button, self.virtual_count):
            w.setEnabled(not busy and has_project and virtual)
        self.capture_button.setEnabled(not busy and has_project and (ready if cameras else virtual))
        self.virtual_button.setToolTip(VIRTUAL_TOOLTIP if virtual else "Only in a virtual-lab project")
        self.capture_button.setToolTip((CAMERA_TOOLTIP_LIVE if ready else CAMERA_TOOLTIP_NO_BOARD) if cameras
                                       else CAMERA_TOOLTIP_VIRTUAL if virtual else CAMERA_TOOLTIP_HARDWARE)
        self.remove_button.setEnabled(not busy and bool(self.strip.selectedItems()))
        self.clear_button.setEnabled(not busy and has_pairs)

    def ask_folder(self, right: bool, start: str) -> str:
        """The folder of the left camera's images (or of mixed leftNN and rightNN images), or of
        the right camera's ('': none chosen)."""
        title = ("Folder of the RIGHT camera's images" if right else
                 "Folder of the LEFT camera's images (or one folder of leftNN and rightNN images)")
        return QFileDialog.getExistingDirectory(self, title, start)

    # -- the pairs ------------------------------------------------------------------------
    def follow(self, model: StereoModel) -> None:
        """Redraw from the model's events: thumbnails added and removed, the board, and the
        verdicts, counts, bars and advice whenever the pairs or the calibration change."""
        model.on("added", lambda added: [self.strip.add(a.key, a.thumbnail, "") for a in added])
        model.on("removed", lambda keys: [self.strip.remove(k) for k in keys])
        model.on("cleared", lambda _: self.strip.clear_all())
        model.on("board", self.set_board)

        def redraw(_=None):
            self.show_pairs(model.items, model.current_result(), model.coverage(), len(model.usable()))
        model.on("pairs", redraw)
        model.on("result", redraw)

    def show_pairs(self, items, result, coverage, usable: int) -> None:
        """Captions, badges and tool tips of every pair (with its error when `result`, a
        calibration of these pairs, is given), the counts, the coverage bars and the advice."""
        rms = {} if result is None else dict(zip(result.view_indices, result.per_view_rms))
        for a in items:
            caption, badge, colour, tip = _verdict(a, result, rms)
            self.strip.update(a.key, caption=caption, badge=badge, badge_colour=colour, tooltip="\n".join(tip))
        total = len(items)
        accepted = sum(1 for a in items if a.detection.accepted)
        dropped = sum(1 for a in items if a.excluded)
        self.count_label.setText(f"<b>{total} pairs</b>: {accepted} accepted, {total - accepted} rejected"
                                 + (f", {dropped} dropped" if dropped else "") + ".")
        self.coverage_bars.set_values(coverage.bars)
        if coverage.enough:
            text = (f"<span style='color:#188038'><b>Enough views</b></span> ({usable} pairs, every bar ≥ "
                    f"{MIN_BAR}): calibrate.")
        elif usable >= MIN_PAIRS_TO_CALIBRATE:
            text = (f"<span style='color:#b06000'><b>Not enough views yet</b></span> — calibrating is possible "
                    f"from {MIN_PAIRS_TO_CALIBRATE} pairs, but the result may be poorly determined. "
                    + "; ".join(esc(a) for a in coverage.advice) + ".")
        else:
            text = ("<b>Add pairs</b>: " + "; ".join(esc(a) for a in coverage.advice)
                    + f". At least {MIN_GOOD_PAIRS} well-spread pairs with every bar ≥ {MIN_BAR}.")
        self.advice.setText(text)


def _verdict(a, result, rms: dict) -> tuple[str, str | None, str, list[str]]:
    """(caption, badge, badge colour, tool tip lines) of one pair on the strip."""
    d = a.detection
    n = d.index + 1
    tip = [f"Pair {n}: {d.name}", f"from the {a.source}"]
    if a.excluded:
        tip.append("Dropped from the calibration (Restore dropped brings it back)")
        return f"{n}  dropped", "dropped by you", MUTED, tip
    if not d.accepted:
        tip.append(f"Rejected: {d.reason}")
        return f"{n}  ✗", short_reason(d.reason), BAD, tip
    badge, colour, caption = None, BAD, f"{n}  ✓"
    if result is not None and d.index in rms:
        caption = f"{n}  ✓ {rms[d.index]:.3f} px"
        if d.index in result.outliers:
            badge, colour = "outlier", WARN
            tip.append(f"Flagged as an outlier: RMS {rms[d.index]:.3f} px > {result.outlier_threshold:.3f} px")
    return caption, badge, colour, tip
