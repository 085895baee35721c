"""What the Stereo page does with a calibration: draw it (results_panel.py) whenever the model's
result changes, drop the pairs above the threshold line and calibrate again, select the flagged
ones, restore the dropped ones, and rectify the previewed pair on a worker (a display only,
beside the page's task). A helper the page holds."""
from __future__ import annotations

from typing import Callable

from app.pages.stereo.model import StereoModel
from app.pages.stereo.pairs_panel import PairsPanel
from app.pages.stereo.results_panel import ResultsPanel, outlier_text
from app.task_handle import CurrentTask
from app.worker import TaskRunner


class ResultActions:
    """`calibrate()` starts a calibration (False: it could not start), `busy()` says whether the
    page's task runs, `busy_changed()` refreshes the page's buttons, `report()` shows the pairs
    in the status line, `set_status(text, ok)` is the status line."""

    def __init__(self, model: StereoModel, panel: ResultsPanel, pairs: PairsPanel, runner: TaskRunner, *,
                 calibrate: Callable[[], bool], busy: Callable[[], bool], busy_changed: Callable[[], None],
                 report: Callable[[], None], set_status: Callable[[str, bool | None], None]):
        self.model, self.panel = model, panel
        self.calibrate, self.busy, self.busy_changed = calibrate, busy, busy_changed
        self.report, self.set_status = report, set_status
        self._preview_task = CurrentTask(runner)       # the latest rectified preview asked for
        model.on("result", self.draw)
        panel.errors_chart.selectionChanged.connect(self._threshold_moved)
        panel.drop_button.clicked.connect(lambda: self.drop_selected())
        panel.flagged_button.clicked.connect(self.select_flagged)
        panel.restore_button.clicked.connect(self.restore_excluded)
        panel.preview_combo.currentIndexChanged.connect(self._preview_changed)
        pairs.strip.currentKeyChanged.connect(self._thumbnail_picked)

    def selected_pairs(self) -> list[int]:
        """Pair indices (0-based) above the threshold line."""
        r = self.model.result
        if r is None:
            return []
        return [r.view_indices[i] for i in self.panel.errors_chart.selected()]

    def select_flagged(self) -> None:
        r = self.model.result
        if r is None or not r.outliers:
            return
        pos = [r.view_position(i) for i in r.outliers]
        lowest = min(max(r.per_view_rms_left[p], r.per_view_rms_right[p]) for p in pos)
        self.panel.errors_chart.set_threshold(lowest * 0.98)

    def drop_selected(self) -> bool:
        r = self.model.result
        chosen = self.selected_pairs()
        if r is None or not chosen:
            self.set_status("Drag the threshold line below the bars of the pairs to drop.", False)
            return False
        if self.busy():
            return False
        self.model.exclude([r.detections.pairs[i] for i in chosen])
        return self.calibrate()

    def restore_excluded(self) -> None:
        self.model.restore()
        self.report()

    def _threshold_moved(self, rows: list) -> None:
        r = self.model.result
        if r is None:
            return
        pairs = [r.view_indices[i] + 1 for i in rows]
        if pairs:
            self.panel.outlier_label.setText(
                f"Above the line: pair{'s' if len(pairs) > 1 else ''} {', '.join(map(str, pairs))} — "
                f"Drop selected & recalibrate removes {'them' if len(pairs) > 1 else 'it'}.")
        else:
            self.panel.outlier_label.setText(outlier_text(r))
        self.busy_changed()

    # -- drawing the result ------------------------------------------------------------------------
    def draw(self, result) -> None:
        """Every tab of the calibration (None: the empty tabs), and its first pair rectified."""
        if result is None:
            self.panel.clear()
        else:
            self.panel.show_result(result)
            self._preview_changed()

    def _preview_changed(self, *_) -> None:
        """Rectify the chosen pair on a worker (beside the page's task: a display only)."""
        r = self.model.result
        index = self.panel.preview_combo.currentData()
        if r is None or index is None:
            return
        v = r.view_position(int(index))
        self.panel.scatter.set_highlight(r.fit.residuals_left[v], r.fit.residuals_right[v], f"pair {int(index) + 1}")
        # the pairs as they were at the calibration (pairs added or removed since renumber the page's)
        pair = r.detections.pairs[int(index)] if r.detections is not None else None
        if pair is None:
            return

        def shown(images):
            if self.model.result is r:
                self.panel.draw_preview(r, v, *images)

        def failed(message):
            self.panel.preview.set_image(None)
            self.panel.preview_caption.setText(message)

        self.panel.preview_caption.setText("Rectifying this pair…")
        self._preview_task.start(r.rectification.rectify_files, pair.left_path, pair.right_path, on_result=shown,
                                 on_error=failed, label="Rectifying the preview")

    def _thumbnail_picked(self, key) -> None:
        """Show the picked pair in the rectified preview when it is part of the calibration."""
        r = self.model.current_result()
        if key is None or r is None:
            return
        for a in self.model.items:
            if a.key == key and a.detection.index in r.view_indices:
                i = self.panel.preview_combo.findData(a.detection.index)
                if i >= 0:
                    self.panel.preview_combo.setCurrentIndex(i)
                return
