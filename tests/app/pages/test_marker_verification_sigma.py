"""The Marker page's verification result says in plain words why the 3D error exceeds the image
noise σ, with the numbers computed: the image-noise σ, and, when the stereo calibration's
parameter covariance is known (stereo.json), the calibration's share and the σ with it."""
from __future__ import annotations

import json
import math
from collections import Counter
from html import unescape

import numpy as np
import pytest

from app.html import number
from app.jobs.marker import VerificationResult, save_trained
from app.pages.marker.page import MarkerPage
from app.pages.marker.verification_panel import VerificationPanel
from app.worker import TaskRunner
from core.stereo.file import read_stereo_yaml
from core.stereo.point_uncertainty import PARAMETERS
from tests.app.virtual_inputs import lab_marker, lab_state, make_lab
from widgets.progress_row import ProgressRow

NAN = float("nan")
WHY = "The calibration's own error is not in it"


def _result(calibration_sigmas=None) -> VerificationResult:
    return VerificationResult(4, "stereo.yaml", np.full(4, 600.0), np.array([0.12, 0.14, NAN, 0.10]),
                              np.array([0.009, 0.008, NAN, 0.010]), np.array([True, True, False, True]),
                              Counter({"outline not found": 1}), calibration_sigmas=calibration_sigmas)


@pytest.fixture
def panel(qtbot):
    p = VerificationPanel(ProgressRow())
    qtbot.addWidget(p)
    p.show()
    return p


def test_the_difference_is_explained_with_the_calibrations_share(panel):
    v = _result(np.array([0.11, 0.13, NAN, 0.12]))
    panel.draw(v)
    text = unescape(panel.verify_summary.text())
    total = float(np.median(np.hypot([0.009, 0.008, 0.010], [0.11, 0.13, 0.12])))
    assert v.median_total_sigma == pytest.approx(total) and v.median_calibration_sigma == pytest.approx(0.12)
    assert f"median σ, image noise&nbsp;</td><td align='right'>{number(0.009, 3, 'mm')}" in text.replace(
        "\xa0", "&nbsp;")
    assert "σ with the stereo calibration" in text and number(total, 3, "mm") in text
    assert "image noise carried through triangulation" in text and WHY in text
    plot = panel.precision_plot                               # both σ drawn, per located pose
    assert (plot.n_errors, plot.n_sigmas, plot.n_totals) == (3, 3, 3)
    np.testing.assert_allclose(plot.totals.getData()[1], np.hypot([0.009, 0.008, 0.010], [0.11, 0.13, 0.12]))
    assert len(plot.legend.items) == 3
    panel.draw(_result())                                     # a run without it: its points and legend go
    assert plot.n_totals == 0 and len(plot.legend.items) == 2
    assert (f"it is {number(0.12, 3, 'mm')} (median); with the image noise, σ = {number(total, 3, 'mm')}, "
            f"to compare with the median error of {number(0.12, 3, 'mm')}") in text


def test_without_the_calibrations_uncertainty_it_says_so(panel):
    v = _result()
    panel.draw(v)
    text = unescape(panel.verify_summary.text())
    assert WHY in text and "σ with the stereo calibration" not in text
    assert "so only the image noise is predicted" in text and math.isnan(v.median_total_sigma)
    assert panel.precision_plot.n_totals == 0 and panel.precision_plot.n_sigmas == 3


def test_the_page_takes_the_covariance_from_the_projects_stereo_json(qtbot, tmp_path):
    """A project with stereo.yaml, its stereo.json (parameters and their covariance) and a
    trained marker: the verification shows the calibration's share of σ."""
    lab = make_lab()
    state, tasks = lab_state(lab), TaskRunner()
    project = state.project
    sf = read_stereo_yaml(project.path("stereo"))
    rows = [{"group": g, "name": "fx", "value": float(k[0, 0]), "std": 0.1} for g, k in (("left", sf.K1),
                                                                                          ("right", sf.K2))]
    rows += [{"group": "stereo", "name": n, "value": float(t), "std": 0.01} for n, t in zip(("tx", "ty", "tz"), sf.T)]
    cov = np.diag([0.1 ** 2] * 8 + [0.005 ** 2] * 3 + [0.01 ** 2] * 3)
    project.path("stereo_details").write_text(json.dumps({"parameters": rows, "parameter_covariance": {
        "names": list(PARAMETERS), "units": "px, deg, mm", "matrix": cov.tolist()}}))
    save_trained(project, lab_marker(lab))
    page = MarkerPage(state, tasks)
    qtbot.addWidget(page)
    page.resize(1100, 760)
    page.show()
    try:
        state.projectChanged.emit(project)                  # the page takes the saved marker
        page.on_enter()
        assert page.model.result.trained is not None and page.model.stereo.kind == "file"
        page.verification_panel.verify_spin.setValue(3)
        assert page.verify()
        qtbot.waitUntil(lambda: not page.task.busy, timeout=60000)
        v = page.model.result.verification
        assert v.n_located >= 2 and np.all(np.isfinite(v.calibration_sigmas[v.located]))
        text = unescape(page.verification_panel.verify_summary.text())
        assert number(v.median_total_sigma, 3, "mm") in text and number(v.median_sigma, 3, "mm") in text
        assert WHY in text and "σ with the stereo calibration" in text
        shot = tmp_path / "verification.png"
        assert page.grab().save(str(shot)) and shot.stat().st_size > 10000
    finally:
        tasks.shutdown()
        state.close()
