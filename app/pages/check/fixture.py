"""The Check page's fixture: located from the virtual lab's fixture or from a fixture description
and a folder of image pairs (app/jobs/fixture.py, on a worker) through the calibration, written to
the project (fixture_pose.json, fixture.urdf), and put into the model (the Fixture panel draws it).

A helper the page holds (`FixtureLocator`), given the Fixture panel it reads the choices from.
"""
from __future__ import annotations

from typing import Callable

from app.jobs import fixture as fixture_job
from app.pages.check.fixture_panel import FixturePanel
from app.pages.check.inputs import CheckInputs
from app.pages.check.model import CheckModel
from app.pages.check.texts import MISSING
from app.pages.page_task import PageTask


class FixtureLocator:
    """Locate the fixture chosen on `panel` (`set_status(text, ok)`: the page's status line)."""

    def __init__(self, model: CheckModel, panel: FixturePanel, inputs: CheckInputs, task: PageTask,
                 set_status: Callable):
        self.model = model
        self.panel = panel
        self.inputs = inputs
        self.task = task
        self._set_status = set_status

    def locate(self) -> bool:
        """Locate the lab's fixture, or the chosen description's from its pairs folder, through the
        calibration; write fixture_pose.json and fixture.urdf to the project."""
        if not self.inputs.ready():
            self._set_status(MISSING, False)
            return False
        images = self.inputs.images()
        if images is None:
            self._set_status("Locating a fixture needs the trained marker and the stereo calibration: run the "
                             "Stereo and Marker steps first.", False)
            return False
        folder, calibrated = self.inputs.state.project.folder, self.inputs.calibrated_path()
        if self.panel.source == "lab":
            if not self.inputs.state.virtual:
                self._set_status("The lab's fixture needs a virtual-lab project; choose image pairs.", False)
                return False
            return self.task.start_with_lab(fixture_job.locate_on_lab, calibrated, *images, folder,
                                            seed=self.model.result.next_seed(), on_done=self._located,
                                            status="Locating the lab's fixture…")
        if not self.panel.description_path or not self.panel.pairs_folder:
            self._set_status("Choose the fixture description and the folder of image pairs first.", False)
            return False
        return self.task.start(fixture_job.locate_from_folder, calibrated, *images, self.panel.description_path,
                               self.panel.pairs_folder, folder, on_done=self._located,
                               status="Locating the fixture…")

    def _located(self, run: fixture_job.FixtureRun) -> None:
        self.model.take_fixture(run)
        f = run.result.frame
        self._set_status(f"✓ Fixture located ({f.method}, RMS residual {f.rms_mm:.3f} mm): wrote "
                         f"{run.pose_path.name} and {run.urdf_path.name}.", True)
