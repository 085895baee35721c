"""The Stereo page's checkerboard pairs: where pairs come from (folders, virtual lab, cameras),
the board definition, the thumbnails with their verdicts, and the ROS-style coverage bars.
`PairsPanel` shows them; `PairsActions` (part of the page) adds, removes and redetects pairs
on the worker thread (app/jobs/stereo.py)."""
from __future__ import annotations

from functools import partial
from pathlib import Path
from typing import Callable, Sequence

from PySide6.QtCore import QSize, Qt
from PySide6.QtWidgets import QFileDialog, QGroupBox, QLabel, QVBoxLayout

from app.html import esc
from app.jobs.stereo import THUMB_WIDTH, AddedPair, board_poses, detect_files, next_free_number, render_pairs
from app.pages.forms import button, double_spin, row, spin
from app.pages.stereo.live_capture import capture_live_pair
from app.pages.stereo.texts import BAR_TIPS, CAMERA_TOOLTIP_HARDWARE, CAMERA_TOOLTIP_NO_BOARD, short_reason
from core.errors import RoboCalError
from core.stereo.board import Board
from core.stereo.screening import screen_pairs
from core.stereo.coverage import MIN_BAR, MIN_GOOD_PAIRS, MIN_PAIRS_TO_CALIBRATE, coverage
from core.stereo.image_files import pair_images
from core.stereo.image_pairs import split_mixed_folder, swap_camera_folders
from widgets.coverage_bars import CoverageBars
from widgets.flow_layout import FlowLayout
from widgets.thumbnail_strip import BAD, MUTED, WARN, ThumbnailStrip

VIRTUAL_PAIRS = 20
RENDER_CHUNK = 4            # pairs rendered per worker task (thumbnails and bars fill in between)
FILE_CHUNK = 6              # pairs detected per worker task when adding folders


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

    # -- the pairs ------------------------------------------------------------------------
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


class PairsActions:
    """The page's work on its pairs (a part of StereoPage: uses its `items`, `pairs` panel,
    `_board`, job queue and status line)."""

    def _need_project(self) -> bool:
        if self.state.project is None:
            self._set_status("No project yet: create or open one in the Setup step (1).", ok=False)
            return False
        if self.task.busy:
            self._set_status("Busy: wait for the running task or cancel it.", ok=False)
            return False
        return True

    def add_folders_dialog(self) -> bool:
        start = str(self.state.project.folder) if self.state.project is not None else ""
        left = QFileDialog.getExistingDirectory(
            self, "Folder of the LEFT camera's images (or one folder of leftNN and rightNN images)", start)
        if not left:
            return False
        try:
            if split_mixed_folder(left) is not None:
                return self.add_folders(left, left)
        except RoboCalError as exc:
            self._set_status(f"Cannot add this folder: {exc.message}", ok=False)
            return False
        right = QFileDialog.getExistingDirectory(self, "Folder of the RIGHT camera's images", str(Path(left).parent))
        if not right:
            return False
        return self.add_folders(left, right)

    def add_folders(self, left, right, then: Callable[[], None] | None = None) -> bool:
        """Pair the images of two folders by sorted name and detect them on the worker thread.
        Problems with the folders (unequal counts, no images) are shown on the page."""
        if not self._need_project():
            return False
        try:
            pairs, ignored = pair_images(left, right)
        except RoboCalError as exc:
            self._set_status(f"Cannot add these folders: {exc.message}", ok=False)
            return False
        self.ignored_files = list(ignored)
        jobs = self._detect_jobs(pairs, self._board, "folders")
        note = ""
        if ignored:
            shown = ", ".join(ignored[:4]) + (", …" if len(ignored) > 4 else "")
            note = f" Not images, ignored: {shown}."
        n = len(pairs)
        self._set_status(f"Detecting the board in {n} pair{'s' if n != 1 else ''}…{note}")
        self._after_adding_note = note
        self._run_queue(jobs, then=lambda: self._adding_finished(then))
        return True

    def _detect_jobs(self, pairs: list[tuple[Path, Path]], board: Board, sources: str | list[str]) -> list:
        """Queue jobs detecting `pairs` in batches of FILE_CHUNK (thumbnails fill in between),
        their progress numbered over all the pairs."""
        return [(partial(detect_files, pairs[s:s + FILE_CHUNK], board,
                         sources if isinstance(sources, str) else sources[s:s + FILE_CHUNK], first=s, total=len(pairs)),
                 "Detecting checkerboards", self._add) for s in range(0, len(pairs), FILE_CHUNK)]

    def swap_cameras(self) -> bool:
        """Give every pair's images to the other camera, detect them again and calibrate again
        (for a calibration whose right camera came out on the left). The pairs saved in the
        project (checkerboard/left, right) are swapped on disk too, so the project opens right."""
        if not self._need_project() or not self.items:
            return False
        saved = self.state.project.folder / "checkerboard"
        inside = [Path(a.detection.left_path).parent == saved / "left" for a in self.items]
        try:
            moved = any(inside) and swap_camera_folders(saved)
        except (RoboCalError, OSError) as exc:
            self._set_status(f"Cannot swap the saved pairs' folders: {getattr(exc, 'message', exc)}", ok=False)
            return False
        # a saved pair keeps its paths (its folders were exchanged), any other pair exchanges them
        pairs = [(Path(a.detection.left_path), Path(a.detection.right_path)) if moved and here
                 else (Path(a.detection.right_path), Path(a.detection.left_path)) for a, here in zip(self.items, inside)]
        sources = [a.source for a in self.items]
        excluded = [a.excluded for a in self.items]
        self.items.clear()
        self.pairs.strip.clear_all()
        self.result = None
        self._changed()
        jobs = self._detect_jobs(pairs, self._board, sources)

        def detected():
            for a, was in zip(self.items, excluded):
                a.excluded = was
            self._changed()
            self._calibration_note = " Left and right images swapped." + (
                " The cameras opened on the Setup page are still the other way round: swap them there."
                if self.state.hardware.cameras is not None else "")
            if not self.calibrate():
                self._calibration_note = ""
        self._set_status(f"Swapping left and right in {len(pairs)} pairs…")
        self._run_queue(jobs, then=detected)
        return True

    def add_virtual_pairs(self, n: int = VIRTUAL_PAIRS, then: Callable[[], None] | None = None, *,
                          source: str = "virtual lab") -> bool:
        """Render n pairs of the virtual lab's checkerboard (saved into the project), detect them."""
        if not self._need_project():
            return False
        if not self.state.virtual:
            self._set_status("The virtual lab is only available in a virtual-lab project.", ok=False)
            return False
        folder = self.state.project.folder / "checkerboard"
        first = next_free_number(folder)
        seed = int(self.state.seed)
        self._after_adding_note = ""
        self._set_status(f"Rendering {n} virtual-lab pair{'s' if n != 1 else ''}…")

        def render(lab, poses):
            paths = [(folder / "left" / f"pair_{first + i:03d}.png", folder / "right" / f"pair_{first + i:03d}.png")
                     for i in range(len(poses))]
            seeds = [[seed, 11, first + i] for i in range(len(poses))]
            jobs = [(partial(render_pairs, lab, poses[s:s + RENDER_CHUNK], seeds[s:s + RENDER_CHUNK],
                             paths[s:s + RENDER_CHUNK], self._board, source, first=s, total=len(poses)),
                     "Rendering virtual-lab pairs", self._add) for s in range(0, len(poses), RENDER_CHUNK)]
            self._queue[:0] = jobs
            self._queue_total += len(jobs)

        def with_lab(lab):
            self._run_queue([(partial(board_poses, lab, int(n), [seed, 10, first]), "Preparing the virtual lab",
                              partial(render, lab))], then=lambda: self._adding_finished(then))

        self._wait_for_lab(with_lab)
        return True

    def capture_pair(self) -> bool:
        """With the cameras opened on the Setup page, the pair the live view shows, while the
        board is seen in both of its images (live_preview.py, saved by live_capture.py); without
        them, in the virtual lab, one pair from the lab's cameras with the board at a random pose."""
        if self.state.hardware.cameras is not None:
            pair = self.live.ready_pair()
            if pair is None:
                self._set_status(CAMERA_TOOLTIP_NO_BOARD, ok=False)
                return False
            if not capture_live_pair(self, pair.left, pair.right):
                return False
            self.live.saved(pair)
            return True
        if not self.state.virtual:
            self._set_status(CAMERA_TOOLTIP_HARDWARE, ok=False)
            return False
        return self.add_virtual_pairs(1, source="virtual camera")

    def _adding_finished(self, then: Callable[[], None] | None) -> None:
        self._report_pairs(self._after_adding_note)
        if then is not None:
            then()

    def _add(self, added: list[AddedPair]) -> None:
        """New pairs from a worker: screened again with the others, shown, coverage updated."""
        for a in added:
            a.key = next(self._keys)
            self.items.append(a)
            self.pairs.strip.add(a.key, a.thumbnail, "")
        self._changed()

    def remove_pairs(self, keys: Sequence[int]) -> None:
        if self.task.busy or not keys:
            return
        gone = set(keys)
        for a in [a for a in self.items if a.key in gone]:
            self.items.remove(a)
            self.pairs.strip.remove(a.key)
        self._changed()
        self._report_pairs()

    def clear_pairs(self) -> None:
        if self.task.busy:
            return
        self.items.clear()
        self.pairs.strip.clear_all()
        self._changed()
        self._report_pairs()

    def set_board(self, board: Board) -> None:
        self.pairs.set_board(board)
        self.apply_board()

    def apply_board(self) -> None:
        """The board definition changed: redetect every pair when the corner grid changed,
        or only screen them again when the square size changed."""
        self._board_timer.stop()
        new = self.pairs.board()
        if new == self._board:
            return
        if self.task.busy:                      # after the running task
            self._board_timer.start()
            return
        old, self._board = self._board, new
        if not self.items:
            self._changed()
            return
        if (old.cols, old.rows) == (new.cols, new.rows):
            self._changed()
            self._set_status(f"Square size {new.square:g} mm: calibrate again to use it.")
            return
        pairs = [(Path(a.detection.left_path), Path(a.detection.right_path)) for a in self.items]
        sources = [a.source for a in self.items]
        self.items.clear()
        self.pairs.strip.clear_all()
        self._changed()
        jobs = self._detect_jobs(pairs, new, sources)
        self._set_status(f"Board {new.cols}x{new.rows}: detecting the board again in {len(pairs)} pairs…")
        self._after_adding_note = ""
        self._run_queue(jobs, then=lambda: self._adding_finished(None))

    def _coverage(self):
        return coverage([a.detection for a in self.usable_pairs()])

    def _changed(self) -> None:
        """Pairs or board changed: screen all pairs again, redraw thumbnails and bars."""
        dets = [a.detection for a in self.items]
        self.detections = screen_pairs(dets, self._board) if dets else None
        if self.result is not None:
            self.result_stale = True
        self._refresh_pairs()

    def _refresh_pairs(self) -> None:
        result = self.result if not self.result_stale else None
        self.pairs.show_pairs(self.items, result, self._coverage(), len(self.usable_pairs()))
        self.on_busy_changed()

    def _report_pairs(self, note: str = "") -> None:
        total = len(self.items)
        rejected = [a.detection for a in self.items if not a.detection.accepted]
        text = f"{total} pair{'s' if total != 1 else ''} on the page"
        if rejected:
            shown = "; ".join(f"pair {d.index + 1}: {d.reason}" for d in rejected[:3])
            text += f"; {len(rejected)} rejected ({shown}{'; …' if len(rejected) > 3 else ''})"
        text += "." + note
        if self.result is not None and self.result_stale:
            text += " Pairs changed since the calibration: calibrate again."
        self._set_status(text, ok=None if not rejected else False)

    def _thumbnail_picked(self, key) -> None:
        """Show the picked pair in the rectified preview when it is part of the calibration."""
        if key is None or self.result is None or self.result_stale:
            return
        for a in self.items:
            if a.key == key and a.detection.index in self.result.view_indices:
                i = self.results.preview_combo.findData(a.detection.index)
                if i >= 0:
                    self.results.preview_combo.setCurrentIndex(i)
                return
