"""What the Check page reads from the project: the calibrated robot, the check log's place, the
trained marker and stereo rectification its checks measure through, and what the check poses
were chosen for."""
from __future__ import annotations

from pathlib import Path
from typing import Callable

from app.jobs.cell_measure import cell_options
from app.pages.check.model import CheckOptions
from app.pages.measurement_inputs import project_marker, stereo_source
from core.errors import RoboCalError
from core.project import Output

LOG_NAME = "checks.csv"


class CheckInputs:
    """The project's files and choices a check needs (`options()`: the page's current options)."""

    def __init__(self, state, options: Callable[[], CheckOptions]):
        self.state = state
        self._options = options

    def calibrated_path(self) -> Path | None:
        return self.state.project.path(Output.CALIBRATED) if self.state.project is not None else None

    def log_path(self) -> Path | None:
        return self.state.project.folder / LOG_NAME if self.state.project is not None else None

    def ready(self) -> bool:
        """The project has a calibrated robot (calibrated.json)."""
        path = self.calibrated_path()
        return path is not None and path.is_file()

    def key(self) -> tuple:
        """What check poses are chosen for: (calibrated file, its mtime, pose count, tool)."""
        path, options = self.calibrated_path(), self._options()
        return (str(path), path.stat().st_mtime_ns, options.count, options.tool)

    @property
    def teach_mode(self) -> bool:
        """A real cell whose robot the technician brings to each pose (the project's choice)."""
        return self.state.project is not None and self.state.project.teach_mode

    def images(self):
        """(trained marker, stereo rectification) when the project has both: checks then measure
        through rendered images, as the calibration did; None: the lab's ideal measurements."""
        try:
            trained = project_marker(self.state)
        except RoboCalError:
            return None
        rect = stereo_source(self.state).rect
        return (trained, rect) if trained is not None and rect is not None else None

    def cell_options(self) -> dict:
        """How the real cell's poses are chosen: its calibrated cameras and measured depths."""
        return cell_options(stereo_source(self.state).rect.calibration.rig,
                            self.state.project.path(Output.MEASUREMENTS))
