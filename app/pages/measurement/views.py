"""Top and side views of the measured points, the poses still to measure (nominal model), the
selected pose's arm and the cameras, in the left camera frame (mm); they follow the page's
MeasurementModel."""
from __future__ import annotations

from typing import Callable

import numpy as np

from app.jobs.measurement import MEASURED, PENDING, RUNNING, PoseRow, nominal_arm, nominal_predictions
from widgets.plot_theme import AFTER, colour
from widgets.workspace_views import ARM, CAMERA, CANDIDATE, HIGHLIGHT, WorkspaceViews, camera_wedges

CAPTION = (f"<span style='color:{AFTER}'>●</span> measured marker positions &nbsp; "
           f"<span style='color:{CANDIDATE}'>●</span> poses still to measure (nominal model) &nbsp; "
           f"<span style='color:{ARM}'>━●━</span> nominal arm in the selected pose, "
           f"<span style='color:{HIGHLIGHT}'>●</span> its measured marker &nbsp; "
           f"<span style='color:{CAMERA}'>▲</span> cameras (stereo.yaml)")


class MeasurementViews(WorkspaceViews):
    """WorkspaceViews with the page's caption; the poses still to measure plainly visible.
    The nominal model's predictions need the virtual lab (none outside it); they are kept until
    `forget_predictions()` (another pose list or lab). After `follow(model, ...)` they redraw on
    the model's "rows" and "pose" events."""

    def __init__(self, parent=None):
        super().__init__(title_top="Top view (x–z, left camera frame)",
                         title_side="Side view (z–y, left camera frame)", parent=parent)
        self.caption.setText(CAPTION)
        for view in self.views:
            view.candidates.setSize(6)
            view.candidates.setBrush(colour(CANDIDATE, 190))
        self._predicted = self._arms = None
        self._wedges = None
        self._model = None
        self._lab: Callable = lambda: None
        self._selected: Callable[[], int | None] = lambda: None

    def follow(self, model, *, lab: Callable, selected: Callable[[], int | None]) -> None:
        """Draw `model` (a MeasurementModel) as it changes: `lab()` is the virtual lab or None (the
        nominal model's predictions need it), `selected()` the row whose arm is drawn."""
        self._model, self._lab, self._selected = model, lab, selected
        model.on("rows", lambda _rows: self.redraw())
        model.on("pose", lambda shown: self.redraw(shown.index))

    def set_cameras(self, rect) -> None:
        """The cameras of the stereo rectification `rect` (None: none drawn), up to 1 m deep."""
        self._wedges = camera_wedges(rect.rig, 1000.0) if rect is not None else None

    def redraw(self, highlight: int | None = None) -> None:
        """The followed model's rows; the arm of row `highlight` (None: the selected row)."""
        if self._model is not None:
            self.show_rows(self._model.rows, self._model.joints(), self._lab(), self._wedges,
                           self._selected() if highlight is None else highlight)

    def highlight_selected(self) -> None:
        if self._model is not None:
            self.highlight_row(self._model.rows, self._model.joints(), self._lab(), self._selected())

    def forget_predictions(self) -> None:
        self._predicted = self._arms = None

    def lab_changed(self, lab) -> None:
        """Another virtual lab (None: none yet): its nominal model's predictions are drawn."""
        if lab is not None:
            self.forget_predictions()
            self.redraw()

    def _predictions(self, Q, lab):
        """Marker positions of every pose by the lab's placed nominal robot; None outside the lab."""
        if self._predicted is None and Q is not None and lab is not None:
            try:
                self._predicted, self._arms = nominal_predictions(lab, Q)
            except Exception:  # noqa: BLE001 - a drawing aid only
                self._predicted = self._arms = None
        return self._predicted

    def show_rows(self, rows: list[PoseRow], Q, lab, wedges, selected: int | None) -> None:
        """The measured points of `rows`, the predictions of those still to measure (Q: every
        pose's joint values), the camera `wedges`, and the `selected` row's arm."""
        measured = np.array([r.point for r in rows if r.status == MEASURED and r.point is not None]).reshape(-1, 3)
        predicted = self._predictions(Q, lab)
        if predicted is not None:
            todo = [r.index for r in rows if r.status in (PENDING, RUNNING)]
            predicted = predicted[todo] if todo else None
        self.set_scene(wedges=wedges, candidates=predicted, selected=measured, extent=self._arms)
        self.highlight_row(rows, Q, lab, selected)

    def highlight_row(self, rows: list[PoseRow], Q, lab, i: int | None) -> None:
        """Row i: the nominal arm in its pose (virtual lab) and its measured marker."""
        if i is None or not 0 <= i < len(rows):
            self.set_highlight(None)
            return
        arm = None
        if lab is not None and Q is not None:
            try:
                arm = nominal_arm(lab, Q[i])
            except Exception:  # noqa: BLE001 - a drawing aid only
                arm = None
        marker = rows[i].point[None, :] if rows[i].point is not None else None
        if arm is None and marker is None:
            self.set_highlight(None)
        elif arm is None:
            self.set_highlight(marker, marker)
        else:
            self.set_highlight(arm, marker)
