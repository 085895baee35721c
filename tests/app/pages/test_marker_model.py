"""The Marker step's model without Qt (options and results with their events), and the panels'
options: what each panel shows is what `options()` returns, `show_options` binds it back, and a
change in a panel reaches the page's model."""
from __future__ import annotations

import numpy as np
import pytest

from app.jobs.marker import TrainingImage
from app.lab import ImagingConditions
from app.pages.marker.model import (ComparisonOptions, ConditionsOptions, MarkerModel, MarkerOptions,
                                    TrainingOptions, VerificationOptions)
from app.pages.measurement_inputs import StereoSource
from core.marker.location import MarkerLocator
from tests.app.pages.model_events import heard
from tests.app.virtual_inputs import lab_marker, make_lab


@pytest.fixture(scope="module")
def lab():
    return make_lab()


def test_options_are_heard_only_when_they_change():
    model = MarkerModel()
    said = heard(model, "options")
    model.choose(verification=VerificationOptions(20))                # the default: no change
    assert said == []
    model.choose(verification=VerificationOptions(7), conditions=ConditionsOptions(ImagingConditions(0.3), 2))
    assert len(said) == 1 and said[0][1] is model.options
    assert model.options.verification.poses == 7 and model.options.conditions.conditions.light == 0.3
    assert model.options.training == TrainingOptions() and model.options.comparison == ComparisonOptions()


def test_a_new_marker_or_stereo_makes_a_new_locator_and_another_project_forgets(lab):
    from app.pages.measurement_inputs import preview_source

    model = MarkerModel()
    said = heard(model, "trained", "live", "verification", "verified", "stereo", "result")
    assert model.locator() is None and not model.ready
    marker = lab_marker(lab)
    image = TrainingImage(marker.image, "virtual lab camera", marker.outline)
    model.set_trained(marker, (10, 20), None, image)
    assert model.locator() is None                                     # no stereo yet
    model.set_stereo(preview_source(lab))
    locator = model.locator()
    assert isinstance(locator, MarkerLocator) and model.ready and model.locator() is locator
    model.set_stereo(preview_source(lab))                               # the same source: the same locator
    assert model.locator() is locator
    model.set_stereo(StereoSource(model.stereo.rect, "file", "stereo.yaml"))
    assert model.locator() is not locator
    locator = model.locator()
    model.set_trained(marker, (0, 0))                                   # trained again on the same image
    assert model.locator() is not locator and model.result.training_image is image
    np.testing.assert_array_equal(model.result.offset, [0.0, 0.0])
    model.set_verified(True)
    said.clear()
    model.forget()
    r = model.result
    assert r.trained is None and r.training_image is None and not r.verified and r.live is None
    events = [e for e, _ in said if e != "result"]
    assert events == ["trained", "verified", "live", "verification"]
    assert dict(said)["trained"].trained is None and model.locator() is None


def test_the_panels_options_are_what_they_show_and_bind_back(qtbot):
    from app.pages.marker.compare_panel import ComparePanel
    from app.pages.marker.conditions_panel import ConditionsPanel
    from app.pages.marker.training_panel import TrainingPanel
    from app.pages.marker.verification_panel import VerificationPanel
    from widgets.progress_row import ProgressRow

    panels = TrainingPanel(), VerificationPanel(ProgressRow()), ComparePanel(), ConditionsPanel()
    for p in panels:
        qtbot.addWidget(p)
    training, verification, compare, conditions = panels
    defaults = MarkerOptions()
    assert (training.options(), verification.options(), compare.options(), conditions.options()) == (
        defaults.training, defaults.verification, defaults.comparison, defaults.conditions)
    chosen = ConditionsOptions(ImagingConditions(light=0.4, occlusion=0.25, side="left", tilt=35.0), 3)
    with qtbot.waitSignal(conditions.optionsChanged):
        conditions.show_options(chosen)
    assert conditions.options() == chosen and conditions.tilt_spin.value() == 35
    assert conditions.light_label.text() == "0.40×" and conditions.side_combo.currentText() == "left"
    verification.show_options(VerificationOptions(12))
    compare.show_options(ComparisonOptions(40))
    training.show_options(TrainingOptions(45.5))
    assert (verification.verify_spin.value(), compare.compare_spin.value(), training.size_spin.value()) == (12, 40, 45.5)
    assert training.options() == TrainingOptions(45.5, None)


def test_a_change_in_a_panel_reaches_the_model_and_the_autopilot_choice_the_panel(qtbot, lab):
    from app.pages.marker.autopilot import DEMO_VERIFY
    from app.pages.marker.page import MarkerPage
    from app.worker import TaskRunner
    from tests.app.virtual_inputs import lab_state

    state, tasks = lab_state(lab), TaskRunner()
    page = MarkerPage(state, tasks)
    qtbot.addWidget(page)
    try:
        page.conditions_panel.occlusion_spin.setValue(30)
        page.compare_panel.compare_spin.setValue(9)
        assert page.model.options.conditions.conditions.occlusion == 0.3
        assert page.model.options.comparison.views == 9
        page.model.choose(verification=VerificationOptions(DEMO_VERIFY))
        assert page.verification_panel.verify_spin.value() == DEMO_VERIFY
        assert page.compare_panel.compare_spin.value() == 9                  # the others keep what was chosen
    finally:
        tasks.shutdown()
        state.close()
