"""Which class is the page of each step. To drop in a real page, change its one line below
(the class is imported only when the window is built, so a page module may import freely).

A not-built step uses NotBuiltPage, which reads the issue number and the description of
the step from app/pages/steps.py.
"""
from __future__ import annotations

import importlib
import logging
import traceback

from app.pages.steps import Step

log = logging.getLogger(__name__)

NOT_BUILT = "app.pages.not_built:NotBuiltPage"

PAGES: dict[Step, str] = {
    Step.SETUP: "app.pages.setup_page:SetupPage",
    Step.STEREO: "app.pages.stereo_page:StereoPage",            # issue 3
    Step.MARKER: "app.pages.marker_page:MarkerPage",            # issue 4
    Step.POSES: "app.pages.poses_page:PosesPage",
    Step.MEASUREMENT: "app.pages.measurement_page:MeasurementPage",    # issue 4
    Step.IDENTIFICATION: "app.pages.identification_page:IdentificationPage",    # issue 5
    Step.EXPORT: "app.pages.export_page:ExportPage",            # issue 5
}


def page_class(step: Step):
    """Import the page class registered for `step` ("module:Class")."""
    module_name, _, class_name = PAGES[step].partition(":")
    return getattr(importlib.import_module(module_name), class_name)


def create_page(step: Step, state, tasks):
    """Build the page of `step`; a page that fails to import or to build is replaced by a
    page showing the error (logged with its traceback), so the wizard still opens."""
    try:
        return page_class(step)(state, tasks, step=step)
    except Exception as exc:  # noqa: BLE001 - shown on the page and logged
        log.error("page %s (%s) failed to load:\n%s", step.name, PAGES[step], traceback.format_exc())
        from app.pages.not_built import PageLoadErrorPage
        from app.worker import error_message
        return PageLoadErrorPage(state, tasks, step=step, error=error_message(exc))


def create_pages(state, tasks) -> list:
    return [create_page(step, state, tasks) for step in Step]
