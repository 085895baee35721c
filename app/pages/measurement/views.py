"""Top and side views of the measured points, the poses still to measure (nominal model), the
selected pose's arm and the cameras, in the left camera frame (mm)."""
from __future__ import annotations

import numpy as np

from app.jobs.measurement import MEASURED, PENDING, RUNNING, PoseRow, nominal_arm, nominal_predictions
from widgets.plot_theme import AFTER, colour
from widgets.workspace_views import ARM, CAMERA, CANDIDATE, HIGHLIGHT, WorkspaceViews

CAPTION = (f"<span style='color:{AFTER}'>●</span> measured marker positions &nbsp; "
           f"<span style='color:{CANDIDATE}'>●</span> poses still to measure (nominal model) &nbsp; "
           f"<span style='color:{ARM}'>━●━</span> nominal arm in the selected pose, "
           f"<span style='color:{HIGHLIGHT}'>●</span> its measured marker &nbsp; "
           f"<span style='color:{CAMERA}'>▲</span> cameras (stereo.yaml)")


class MeasurementViews(WorkspaceViews):
    """WorkspaceViews with the page's caption; the poses still to measure plainly visible.
    The nominal model's predictions need the virtual lab (none outside it); they are kept until
    `forget_predictions()` (another pose list or lab)."""

    def __init__(self, parent=None):
        super().__init__(title_top="Top view (x–z, left camera frame)",
                         title_side="Side view (z–y, left camera frame)", parent=parent)
        self.caption.setText(CAPTION)
        for view in self.views:
            view.candidates.setSize(6)
            view.candidates.setBrush(colour(CANDIDATE, 190))
        self._predicted = self._arms = None

    def forget_predictions(self) -> None:
        self._predicted = self._arms = None

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
