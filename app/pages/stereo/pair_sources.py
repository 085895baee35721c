"""Where the Stereo page's checkerboard pairs come from, and the board they show: two folders,
the virtual lab, the cameras opened on the Setup page; remove, clear, swap left and right, and
a board edit (redetect or screen again). A helper the page holds: it changes the step's model
(model.py), never the panels directly, and runs every addition as ONE worker job
(app/jobs/stereo_pairs.py, live_capture.py) whose finished batches come back here through a
queued signal, so thumbnails fill while the job runs and Cancel keeps what was finished."""
from __future__ import annotations

from pathlib import Path
from typing import Callable, Sequence

from PySide6.QtCore import QObject, QTimer, Signal, Slot

from app.jobs.stereo import next_free_number
from app.jobs.stereo_pairs import detect_in_batches, render_virtual_pairs
from app.pages.page_task import BUSY, PageTask
from app.pages.stereo.live_capture import save_checkerboard_pair
from app.pages.stereo.live_preview import LivePreviewPanel
from app.pages.stereo.model import StereoModel
from app.pages.stereo.pairs_panel import VIRTUAL_PAIRS, PairsPanel
from app.pages.stereo.texts import CAMERA_TOOLTIP_HARDWARE, CAMERA_TOOLTIP_NO_BOARD, pairs_status
from core.errors import RoboCalError
from core.stereo.board import Board
from core.stereo.image_files import pair_images
from core.stereo.image_pairs import split_mixed_folder, swap_camera_folders

BOARD_EDIT_DELAY_MS = 600       # a board edit applies once the spin boxes rest this long


class PairSources(QObject):
    """Adds, removes and redetects the pairs of `model`. `set_status(text, ok)` is the page's
    status line, `on_failed(message)` its answer to a failed wait for the lab, and
    `calibrate(note)` starts a calibration (after a swap)."""

    _arrived = Signal(object, object)        # (run, pairs): a batch of the running job, from its worker

    def __init__(self, state, model: StereoModel, panel: PairsPanel, live: LivePreviewPanel, task: PageTask, *,
                 set_status: Callable[[str, bool | None], None], on_failed: Callable[[str], None],
                 calibrate: Callable[[str], bool], parent: QObject | None = None):
        super().__init__(parent)
        self.state, self.model, self.panel, self.live, self.task = state, model, panel, live, task
        self.set_status, self.on_failed, self.calibrate = set_status, on_failed, calibrate
        self._run: object | None = None       # the job whose batches are still wanted
        self._arrived.connect(self._add_batch)
        self.board_timer = QTimer(self)
        self.board_timer.setSingleShot(True)
        self.board_timer.setInterval(BOARD_EDIT_DELAY_MS)
        self.board_timer.timeout.connect(self.apply_board)
        for w in (panel.cols_spin, panel.rows_spin, panel.square_spin):
            w.valueChanged.connect(lambda *_: self.board_timer.start())

    def _can_start(self) -> bool:
        if self.state.project is None:
            self.set_status("No project yet: create or open one in the Setup step (1).", False)
            return False
        if self.task.busy:
            self.set_status(BUSY, False)
            return False
        return True

    # -- adding -------------------------------------------------------------------------------
    def add_folders_dialog(self) -> bool:
        start = str(self.state.project.folder) if self.state.project is not None else ""
        left = self.panel.ask_folder(False, start)
        if not left:
            return False
        try:
            if split_mixed_folder(left) is not None:
                return self.add_folders(left, left)
        except RoboCalError as exc:
            self.set_status(f"Cannot add this folder: {exc.message}", False)
            return False
        right = self.panel.ask_folder(True, str(Path(left).parent))
        if not right:
            return False
        return self.add_folders(left, right)

    def add_folders(self, left, right, then: Callable[[], None] | None = None) -> bool:
        """Pair the images of two folders by sorted name and detect them on the worker thread.
        Problems with the folders (unequal counts, no images) are shown on the page."""
        if not self._can_start():
            return False
        try:
            pairs, ignored = pair_images(left, right)
        except RoboCalError as exc:
            self.set_status(f"Cannot add these folders: {exc.message}", False)
            return False
        self.model.ignored_files = list(ignored)
        note = ""
        if ignored:
            shown = ", ".join(ignored[:4]) + (", …" if len(ignored) > 4 else "")
            note = f" Not images, ignored: {shown}."
        n = len(pairs)
        self.set_status(f"Detecting the board in {n} pair{'s' if n != 1 else ''}…{note}", None)
        return self._start(detect_in_batches, pairs, self.model.board, "folders", label="Detecting checkerboards",
                           done=self._reported(note, then))

    def add_virtual_pairs(self, n: int = VIRTUAL_PAIRS, then: Callable[[], None] | None = None, *,
                          source: str = "virtual lab") -> bool:
        """Render n pairs of the virtual lab's checkerboard (saved into the project), detect them."""
        if not self._can_start():
            return False
        if not self.state.virtual:
            self.set_status("The virtual lab is only available in a virtual-lab project.", False)
            return False
        folder = self.state.project.folder / "checkerboard"
        first, seed = next_free_number(folder), int(self.state.seed)
        self.set_status(f"Rendering {n} virtual-lab pair{'s' if n != 1 else ''}…", None)
        self.task.follow_lab(lambda lab: self._start(
            render_virtual_pairs, lab, int(n), folder, self.model.board, seed=seed, first=first, source=source,
            label="Rendering virtual-lab pairs", done=self._reported("", then)), self.on_failed)
        return True

    def capture_pair(self) -> bool:
        """With the cameras opened on the Setup page, the pair the live view shows, while the
        board is seen in both of its images (live_preview.py, saved by live_capture.py); without
        them, in the virtual lab, one pair from the lab's cameras with the board at a random pose."""
        if self.state.hardware.cameras is not None:
            pair = self.live.ready_pair()
            if pair is None:
                self.set_status(CAMERA_TOOLTIP_NO_BOARD, False)
                return False
            if not self._can_start():
                return False
            self.set_status("Saving the pair from the cameras…", None)
            self._start(save_checkerboard_pair, pair.left, pair.right, self.state.project.folder / "checkerboard",
                        self.model.board, label="Saving a checkerboard pair", done=self._reported("", None))
            self.live.saved(pair)
            return True
        if not self.state.virtual:
            self.set_status(CAMERA_TOOLTIP_HARDWARE, False)
            return False
        return self.add_virtual_pairs(1, source="virtual camera")

    # -- changing the pairs ---------------------------------------------------------------------
    def swap_cameras(self) -> bool:
        """Give every pair's images to the other camera, detect them again and calibrate again
        (for a calibration whose right camera came out on the left). The pairs saved in the
        project (checkerboard/left, right) are swapped on disk too, so the project opens right."""
        items = self.model.items
        if not self._can_start() or not items:
            return False
        saved = self.state.project.folder / "checkerboard"
        inside = [Path(a.detection.left_path).parent == saved / "left" for a in items]
        try:
            moved = any(inside) and swap_camera_folders(saved)
        except (RoboCalError, OSError) as exc:
            self.set_status(f"Cannot swap the saved pairs' folders: {getattr(exc, 'message', exc)}", False)
            return False
        # a saved pair keeps its paths (its folders were exchanged), any other pair exchanges them
        pairs = [(Path(a.detection.left_path), Path(a.detection.right_path)) if moved and here
                 else (Path(a.detection.right_path), Path(a.detection.left_path)) for a, here in zip(items, inside)]
        sources = [a.source for a in items]
        excluded = [a.excluded for a in items]
        self.model.take_all()
        self.model.set_result(None)
        self.model.changed()

        def detected(_count) -> None:
            for a, was in zip(self.model.items, excluded):
                a.excluded = was
            self.model.changed()
            self.calibrate(" Left and right images swapped." + (
                " The cameras opened on the Setup page are still the other way round: swap them there."
                if self.state.hardware.cameras is not None else ""))
        self.set_status(f"Swapping left and right in {len(pairs)} pairs…", None)
        return self._start(detect_in_batches, pairs, self.model.board, sources, label="Detecting checkerboards",
                           done=detected)

    def remove_pairs(self, keys: Sequence[int]) -> None:
        if self.task.busy or not keys:
            return
        self.model.remove(keys)
        self.report()

    def clear_pairs(self) -> None:
        if self.task.busy:
            return
        self.model.clear()
        self.report()

    def set_board(self, board: Board) -> None:
        self.panel.set_board(board)
        self.apply_board()

    def apply_board(self) -> None:
        """The board definition changed: redetect every pair when the corner grid changed,
        or only screen them again when the square size changed."""
        self.board_timer.stop()
        new, old = self.panel.board(), self.model.board
        if new == old:
            return
        if self.task.busy:                      # after the running task
            self.board_timer.start()
            return
        self.model.set_board(new)
        if not self.model.items:
            self.model.changed()
            return
        if (old.cols, old.rows) == (new.cols, new.rows):
            self.model.changed()
            self.set_status(f"Square size {new.square:g} mm: calibrate again to use it.", None)
            return
        taken = self.model.take_all()
        pairs = [(Path(a.detection.left_path), Path(a.detection.right_path)) for a in taken]
        self.model.changed()
        self.set_status(f"Board {new.cols}x{new.rows}: detecting the board again in {len(pairs)} pairs…", None)
        self._start(detect_in_batches, pairs, new, [a.source for a in taken], label="Detecting checkerboards",
                    done=self._reported("", None))

    # -- the running job ------------------------------------------------------------------------
    def _start(self, fn: Callable, *args, label: str, done: Callable[[int], None], **kwargs) -> bool:
        """Run the adding job `fn(*args, shown=…, **kwargs)` as the page's task; its batches go to
        the model as they come, `done(count)` after the last."""
        run = object()
        previous, self._run = self._run, run
        emit = self._arrived.emit
        if self.task.start(fn, *args, shown=lambda pairs: emit(run, pairs), on_done=done, label=label, **kwargs):
            return True
        self._run = previous                    # refused (busy): the running job's batches are still wanted
        return False

    @Slot(object, object)
    def _add_batch(self, run: object, pairs: list) -> None:
        if run is self._run:                    # not a forgotten job's (another project)
            self.model.add(pairs)

    def forget(self) -> None:
        """The project changed: batches of the job still running are no longer wanted."""
        self._run = None

    def _reported(self, note: str, then: Callable[[], None] | None) -> Callable[[int], None]:
        def done(_count: int) -> None:
            self.report(note)
            if then is not None:
                then()
        return done

    def report(self, note: str = "") -> None:
        """The pairs on the page and the rejected ones in the status line."""
        self.set_status(*pairs_status(self.model.items, self.model.result is not None and self.model.stale, note))
