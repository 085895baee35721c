"""The Marker page's verification drawn pose by pose while it runs, and a Cancel that keeps the
poses measured (summary, precision plot, the verification record)."""
from __future__ import annotations

import pytest

from app.jobs.marker import recorded_verification, save_trained
from app.pages.marker.page import MarkerPage
from app.worker import TaskRunner
from tests.app.virtual_inputs import lab_marker, lab_state, make_lab

POSES = 30


@pytest.fixture
def page(qtbot, boxes):
    lab = make_lab()
    state = lab_state(lab)
    save_trained(state.project, lab_marker(lab))
    p = MarkerPage(state, TaskRunner())
    qtbot.addWidget(p)
    p.resize(1100, 700)
    p.show()
    p.on_enter()
    yield p
    p.task.runner.shutdown()
    state.close()


@pytest.mark.no_session_cache          # the run must still be under way at pose 3
def test_points_shown_as_they_come_and_kept_on_cancel(qtbot, page, tmp_path):
    panel = page.verification_panel
    assert page.model.result.trained is not None and not page.is_complete()
    panel.verify_spin.setValue(POSES)
    assert page.verify()
    qtbot.waitUntil(lambda: f"pose 3 of {POSES}" in panel.verify_summary.text(), timeout=120_000)
    assert page.task.busy and "so far" in panel.verify_summary.text()
    assert panel.precision_plot.n_errors + panel.precision_plot.n_sigmas > 0     # drawn while it runs
    page.grab().save(str(tmp_path / "marker-verification-running.png"))
    page.task.cancel()
    qtbot.waitUntil(lambda: not page.task.busy, timeout=60_000)
    v = page.model.result.verification
    assert v is not None and v.cancelled_after is not None and 3 <= v.n < POSES, page.status.text()
    assert f"cancelled after {v.n} of {POSES} poses" in panel.verify_summary.text()
    assert panel.precision_plot.n_errors == int(v.located.sum())                 # the kept points stay drawn
    assert page.status.text().startswith(f"✓ Cancelled after {v.n} of {POSES} poses, those measured are kept.")
    assert page.is_complete() and recorded_verification(page.state.project)
    page.grab().save(str(tmp_path / "marker-verification-cancelled.png"))
