"""The page of each step, and how the window builds them.

A page that fails to build is replaced by a page that shows the error (logged with its
traceback), so the rest of the wizard still opens.
"""
from __future__ import annotations

import logging
import traceback

from app.pages.base import WizardPage
from app.pages.check.page import CheckPage
from app.pages.compensation.page import CompensationPage
from app.pages.export.page import ExportPage
from app.pages.identification.page import IdentificationPage
from app.pages.load_error_page import PageLoadErrorPage
from app.pages.marker.page import MarkerPage
from app.pages.measurement.page import MeasurementPage
from app.pages.poses.page import PosesPage
from app.pages.setup.page import SetupPage
from app.pages.steps import Step
from app.pages.stereo.page import StereoPage
from app.worker import error_message

log = logging.getLogger(__name__)

PAGES: dict[Step, type[WizardPage]] = {
    Step.SETUP: SetupPage,
    Step.STEREO: StereoPage,
    Step.MARKER: MarkerPage,
    Step.POSES: PosesPage,
    Step.MEASUREMENT: MeasurementPage,
    Step.IDENTIFICATION: IdentificationPage,
    Step.EXPORT: ExportPage,
    Step.CHECK: CheckPage,
    Step.COMPENSATION: CompensationPage,
}


def create_page(step: Step, state, tasks) -> WizardPage:
    """Build the page of `step`, or the error page if building it fails."""
    try:
        return PAGES[step](state, tasks, step=step)
    except Exception as exc:  # noqa: BLE001 - shown on the page and logged
        log.error("page %s (%s) failed to load:\n%s", step.name, PAGES[step].__name__, traceback.format_exc())
        return PageLoadErrorPage(state, tasks, step=step, error=error_message(exc))


def create_pages(state, tasks) -> list[WizardPage]:
    return [create_page(step, state, tasks) for step in Step]
