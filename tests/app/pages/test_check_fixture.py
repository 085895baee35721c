"""The Check page's Fixture panel: the lab's fixture located on a worker and written to the
project, a fixture from a description and a folder of pairs, and what is missing said plainly."""
from __future__ import annotations

import cv2
import numpy as np
import pytest

from app.pages.check.page import CheckPage
from app.worker import TaskRunner
from core.fixtures.file import read_fixture_pose
from core.identification.file import write_calibrated_model
from core.identification.solver import identify
from tests.app.virtual_inputs import lab_marker, lab_state, make_lab

TIMEOUT = 120_000


@pytest.fixture(scope="module")
def lab():
    return make_lab()


@pytest.fixture
def page(qtbot, lab):
    from app.lab import ideal_lab_measurements

    state, tasks = lab_state(lab), TaskRunner()
    write_calibrated_model(identify(lab.nominal_robot, ideal_lab_measurements(lab, 50, sigma_mm=0.05, seed=4)),
                           state.project.path("calibrated"))
    p = CheckPage(state, tasks)
    qtbot.addWidget(p)
    p.resize(1100, 900)
    p.show()
    p.on_enter()
    yield p
    tasks.shutdown()
    state.close()


def test_needs_the_trained_marker(page):
    assert page.fixture.locate_button.isEnabled()
    assert not page.locate_fixture()
    assert "trained marker and the stereo calibration" in page.status.text()


def test_lab_fixture_located_and_written(page, qtbot, lab, tmp_path):
    page.state.set_marker(lab_marker(lab))
    assert page.locate_fixture()
    assert not page.fixture.locate_button.isEnabled()
    qtbot.waitUntil(lambda: not page.task.busy, timeout=TIMEOUT)
    run = page.fixture_run
    assert run is not None, page.status.text()
    assert "✓ Fixture located" in page.status.text()
    e, C = run.true_error, run.result.frame.covariance
    assert np.all(np.abs(e) <= 3.5 * np.sqrt(np.diag(C))), e
    back = read_fixture_pose(page.state.project.folder / "fixture_pose.json")
    assert np.allclose(back.frame.matrix, run.result.frame.matrix)
    assert (page.state.project.folder / "fixture.urdf").is_file()
    text = page.fixture.result_label.text()
    assert "against the lab's true pose" in text and "RMS residual" in text
    shot = tmp_path / "check-fixture.png"
    page.grab().save(str(shot))
    assert shot.stat().st_size > 10_000


def test_fixture_from_description_and_pairs(page, qtbot, lab, tmp_path):
    from app.lab import place_fixture, render_fixture_pairs
    from core.fixtures.description import write_fixture_description

    page.state.set_marker(lab_marker(lab))
    page.fixture.source_combo.setCurrentIndex(1)
    assert page.fixture.pairs_button.isEnabled()
    assert not page.locate_fixture()
    assert "Choose the fixture description" in page.status.text()
    fixture = place_fixture(lab, points=[[0, 0, 0], [200, 0, 0], [60, 150, 0]])
    write_fixture_description(tmp_path / "fixture.json", fixture.description(with_positions=False))
    for side in ("left", "right"):
        (tmp_path / "pairs" / side).mkdir(parents=True)
    for name, (left, right) in zip(fixture.names, render_fixture_pairs(lab, fixture, 2)):
        cv2.imwrite(str(tmp_path / "pairs" / "left" / f"{name}.png"), left)
        cv2.imwrite(str(tmp_path / "pairs" / "right" / f"{name}.png"), right)
    page.fixture.description_path = str(tmp_path / "fixture.json")
    page.fixture.pairs_folder = str(tmp_path / "pairs")
    assert page.locate_fixture()
    qtbot.waitUntil(lambda: not page.task.busy, timeout=TIMEOUT)
    frame = page.fixture_run.result.frame
    assert frame.method == "three points" and page.fixture_run.true_error is None
    assert np.linalg.norm(frame.position - fixture.pose[:3, 3]) < 0.2


def test_a_missing_pair_is_one_message(page, qtbot, lab, tmp_path):
    from app.lab import place_fixture
    from core.fixtures.description import write_fixture_description

    page.state.set_marker(lab_marker(lab))
    page.fixture.source_combo.setCurrentIndex(1)
    write_fixture_description(tmp_path / "fixture.json", place_fixture(lab).description())
    (tmp_path / "pairs").mkdir()
    page.fixture.description_path = str(tmp_path / "fixture.json")
    page.fixture.pairs_folder = str(tmp_path / "pairs")
    assert page.locate_fixture()
    qtbot.waitUntil(lambda: not page.task.busy, timeout=TIMEOUT)
    assert page.fixture_run is None and "no left image of the fixture point 'A'" in page.status.text()
