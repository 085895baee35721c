"""Top and side views of the measured points, the poses still to measure (nominal model), the
selected pose's arm and the cameras, in the left camera frame (mm)."""
from __future__ import annotations

from widgets.plot_theme import AFTER, colour
from widgets.workspace_views import ARM, CAMERA, CANDIDATE, HIGHLIGHT, WorkspaceViews

CAPTION = (f"<span style='color:{AFTER}'>●</span> measured marker positions &nbsp; "
           f"<span style='color:{CANDIDATE}'>●</span> poses still to measure (nominal model) &nbsp; "
           f"<span style='color:{ARM}'>━●━</span> nominal arm in the selected pose, "
           f"<span style='color:{HIGHLIGHT}'>●</span> its measured marker &nbsp; "
           f"<span style='color:{CAMERA}'>▲</span> cameras (stereo.yaml)")


class MeasurementViews(WorkspaceViews):
    """WorkspaceViews with the page's caption; the poses still to measure plainly visible."""

    def __init__(self, parent=None):
        super().__init__(title_top="Top view (x–z, left camera frame)",
                         title_side="Side view (z–y, left camera frame)", parent=parent)
        self.caption.setText(CAPTION)
        for view in self.views:
            view.candidates.setSize(6)
            view.candidates.setBrush(colour(CANDIDATE, 190))

    def highlight(self, arm, marker) -> None:
        """The selected pose: its nominal arm (P, 3) and measured marker (1, 3); either may be None."""
        if arm is None and marker is None:
            self.set_highlight(None)
        elif arm is None:
            self.set_highlight(marker, marker)
        else:
            self.set_highlight(arm, marker)
