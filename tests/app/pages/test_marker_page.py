"""The Marker page driven by pytest-qt on the virtual lab: capture and train (worker), the
live pair with every detection layer drawn, the SSD plots, the 3D point, the verification
run, a training image with too few features, the preview without a stereo calibration,
the saved marker on reopening, and the autopilot."""
from __future__ import annotations

import json
from pathlib import Path

import cv2
import numpy as np
import pytest
from PySide6.QtCore import Qt

from app.pages.marker.page import TAB_LIVE, TAB_SSD, MarkerPage
from app.pages.measurement_inputs import MARKER_FILE, TRAINING_FILE, VERIFICATION_FILE
from app.pages.registry import PAGES
from app.pages.steps import Step
from app.worker import TaskRunner
from core.marker.training import TrainedMarker
from core.report import build_report
from core.marker.details_file import DETAILS_FILE, DETAILS_FORMAT, LIVE_IMAGES
from tests.app.virtual_inputs import lab_state, make_lab

@pytest.fixture(scope="module")
def lab():
    return make_lab()


def make_page(qtbot, lab, stereo=True):
    state, tasks = lab_state(lab, stereo=stereo), TaskRunner()
    page = MarkerPage(state, tasks)
    qtbot.addWidget(page)
    page.resize(900, 760)
    page.show()
    page.on_enter()
    return page


@pytest.fixture
def page(qtbot, lab, boxes):
    p = make_page(qtbot, lab)
    yield p
    p.task.runner.shutdown()
    p.state.close()


def wait(qtbot, page, timeout=60000):
    qtbot.waitUntil(lambda: not page.task.busy, timeout=timeout)


def test_registered_for_the_marker_step():
    assert PAGES[Step.MARKER] is MarkerPage


def test_train_locate_plot_and_verify(qtbot, page, boxes, tmp_path):
    state = page.state
    assert not page.is_complete()
    assert "stereo.yaml" in page.stereo_bar.stereo_label.text() and page.model.stereo.kind == "file"
    assert not page.stereo_bar.preview_button.isVisible()
    # a training image from the virtual lab's camera: the outline is found automatically
    qtbot.mouseClick(page.training_panel.capture_button, Qt.MouseButton.LeftButton)
    wait(qtbot, page)
    assert page.model.result.training_image is not None and page.model.result.training_image.outline is not None
    assert page.training_panel.training_view.overlays["auto_outline"].getData()[0] is not None
    # train on a worker: keypoints, outline and reference drawn, files in the project
    qtbot.mouseClick(page.training_panel.train_button, Qt.MouseButton.LeftButton)
    assert page.task.busy
    wait(qtbot, page)
    t = page.model.result.trained
    assert t is not None and t.n_image_features >= 100 and page.status.text().startswith("✓ Trained")
    assert np.allclose(t.reference_px, [239.5, 239.5], atol=0.1)
    assert len(page.training_panel.training_view.overlays["inliers"].data) == t.n_image_features
    assert str(t.n_image_features) in page.training_panel.training_info.text()
    folder = state.project.folder
    assert TrainedMarker.load(folder / MARKER_FILE).n_features == t.n_features
    assert cv2.imread(str(folder / TRAINING_FILE), cv2.IMREAD_GRAYSCALE).shape == t.image.shape
    assert state.marker is t
    assert not page.is_complete()                       # trained, not yet located
    # a live pair: every stage drawn in both images
    with qtbot.waitSignal(page.completeChanged, timeout=60000):
        qtbot.mouseClick(page.live_panel.next_button, Qt.MouseButton.LeftButton)
        wait(qtbot, page)
    live = page.model.result.live
    assert live.location.ok, live.location.reason
    assert page.tabs.currentIndex() == TAB_LIVE
    for view in (page.live_panel.left_view, page.live_panel.right_view):
        assert len(view.overlays["inliers"].data) >= 10
        assert len(view.overlays["edges"].data) >= 50
        assert len(view.overlays["fitted"].getData()[0]) > 0
        assert len(view.overlays["reference"].getData()[0]) > 0
        assert len(view.overlays["roi"].getData()[0]) == 8          # 4 segments
        assert len(view.overlays["sift_outline"].getData()[0]) == 8
    # zoomed on the marker: the view shows about the marker, not the whole 1280 px image
    xr = page.live_panel.left_view.plot.viewRange()[0]
    assert xr[1] - xr[0] < 600
    # the 3D point with its sigma, and the error against the truth
    assert "3D point" in page.live_panel.point_label.text() and "±" in page.live_panel.point_label.text()
    assert live.error < 0.05                             # the true rig: a few thousandths of a mm
    assert "Error against the lab's true marker position" in page.live_panel.point_label.text()
    assert "SIFT matches agree" in page.live_panel.details_label.text()
    # Fig. 16 and Fig. 17
    assert page.ssd_panel.criteria_plot.has_data() and page.ssd_panel.sweep_plot.has_data()
    assert list(page.ssd_panel.sweep_plot.sizes) == list(range(5, 38, 2))
    c = live.location.correspondence
    x, y = page.ssd_panel.criteria_plot.curve.getData()
    assert len(x) == len(c.disparities)
    assert page.ssd_panel.criteria_plot.line.value() == pytest.approx(c.disparity)
    axis = page.ssd_panel.criteria_plot.plot_item.getAxis
    assert axis("bottom").labelText == "disparity (px)"
    assert axis("left").labelText == "SSD criteria (grey level², per pixel)"
    assert "window size" in page.ssd_panel.sweep_plot.plot_item.getAxis("bottom").labelText
    assert page.is_complete() and (folder / VERIFICATION_FILE).is_file()
    page.tabs.setCurrentIndex(TAB_SSD)
    # the verification run over a few random poses
    page.verification_panel.verify_spin.setValue(4)
    qtbot.mouseClick(page.verification_panel.verify_button, Qt.MouseButton.LeftButton)
    assert page.task.progress_row().cancel_button.isEnabled()
    wait(qtbot, page)
    v = page.model.result.verification
    assert v.n == 4 and v.n_located >= 3 and v.median_error < 0.05
    text = page.verification_panel.verify_summary.text()
    assert f"{v.n_located} of 4" in text and "median 3D error" in text and "RMS 3D error" in text
    assert page.verification_panel.precision_plot.n_errors == v.n_located
    assert page.verification_panel.precision_plot.n_sigmas == v.n_located
    assert "Verification" in page.status.text()
    assert_the_report_draws_the_pair_and_the_verification(page)
    assert boxes == []
    shot = tmp_path / "page.png"
    page.grab().save(str(shot))
    assert shot.stat().st_size > 10000


def assert_the_report_draws_the_pair_and_the_verification(page):
    """marker_details.json and the crops hold the last live pair and the verification; the
    report's marker figures show these numbers."""
    folder = page.state.project.folder
    live, v = page.model.result.live, page.model.result.verification
    c = live.location.correspondence
    details = json.loads((folder / DETAILS_FILE).read_text())
    assert details["format"] == DETAILS_FORMAT and details["marker"] == MARKER_FILE
    assert details["live"]["error_mm"] == pytest.approx(live.error, abs=1e-9)
    for side, det, image in (("left", live.location.left, live.left), ("right", live.location.right, live.right)):
        crop = cv2.imread(str(folder / LIVE_IMAGES[side]), cv2.IMREAD_GRAYSCALE)
        record = details["live"]["images"][side]
        x0, y0 = record["origin"]
        assert record["scale"] == 1.0 and crop.shape[0] < 400
        assert np.array_equal(crop, image[y0:y0 + crop.shape[0], x0:x0 + crop.shape[1]])
        assert np.allclose(record["canny"]["reference"], det.outline.reference, atol=1e-4)
        assert record["sift"]["agreeing"] == int(np.count_nonzero(det.area.inliers))
    assert details["verification"]["errors_mm"] == pytest.approx(
        [None if not np.isfinite(e) else e for e in v.errors], abs=1e-6)
    figs = {f.key: f for f in build_report(page.state.project).figures()}
    for key in ("marker_training", "marker_live", "marker_ssd", "marker_sweep", "marker_precision"):
        assert figs[key].unavailable is None and figs[key].panels, key
    left = {s["name"]: s for s in figs["marker_live"].panels[0]["series"]}
    ref = live.location.left.outline.reference
    x0, y0 = details["live"]["images"]["left"]["origin"]
    assert left["reference point"]["x"][0] == pytest.approx(ref[0] - x0 + 0.5, abs=1e-4)
    assert left["reference point"]["y"][0] == pytest.approx(ref[1] - y0 + 0.5, abs=1e-4)
    curve = figs["marker_ssd"].panels[1]["series"][0]
    assert curve["name"] == "C(d), eq. (26)"
    assert min(curve["y"]) == pytest.approx(c.plain_minimum, abs=1e-3)
    assert figs["marker_sweep"].panels[0]["series"][0]["x"] == list(range(5, 38, 2))
    median, rms = (s["y"][0] for s in figs["marker_precision"].panels[0]["series"][2:])
    assert rms == pytest.approx(v.rms_error, abs=1e-6) and median == pytest.approx(v.median_error, abs=1e-6)


def test_too_few_features_says_why(qtbot, page, tmp_path, boxes):
    # a plain black square: the outline is found, but SIFT has almost nothing to match
    img = np.full((400, 400), 215, np.uint8)
    img[100:300, 100:300] = 20
    path = tmp_path / "plain.png"
    cv2.imwrite(str(path), img)
    assert page.load_image(path)
    assert page.model.result.training_image.outline is not None
    assert page.train()
    wait(qtbot, page)
    assert page.model.result.trained is None and not page.is_complete()
    text = page.status.text()
    assert text.startswith("✗") and "SIFT features" in text and "at least 40" in text and "texture" in text
    assert not (page.state.project.folder / MARKER_FILE).exists()
    assert boxes == []                                  # on the page, not in a message box


def test_crop_rectangle_trains_what_is_inside(qtbot, page):
    # the lab's training image with a second, larger dark square beside the marker
    base = page.state.labs.ready_now().render_training_image()
    img = np.full((480, 900), 120, np.uint8)
    img[:, :480] = base
    img[60:420, 520:880] = 10
    path = Path(page.state.project.folder) / "two_squares.png"
    cv2.imwrite(str(path), img)
    assert page.load_image(path)
    page.training_panel.crop_check.setChecked(True)
    assert page.training_panel.training_view.crop_visible
    page.training_panel.training_view.set_crop_box((100, 100, 380, 380))
    page.training_panel._crop_changed(page.training_panel.training_view.crop_box())
    assert "found" in page.status.text()
    assert page.train()
    wait(qtbot, page)
    t = page.model.result.trained
    assert t is not None, page.status.text()
    assert t.image.shape == (280, 280)                  # trained on the crop
    assert np.allclose(page.model.result.offset, [100, 100])
    assert np.allclose(t.reference_px + page.model.result.offset, [239.5, 239.5], atol=0.2)


def test_preview_with_the_true_cameras_without_stereo(qtbot, lab, boxes):
    page = make_page(qtbot, lab, stereo=False)
    try:
        assert page.model.stereo.rect is None and page.stereo_bar.preview_button.isVisibleTo(page)
        assert "no stereo calibration" in page.stereo_bar.stereo_label.text()
        assert page.use_preview()
        assert page.model.stereo.kind == "preview" and "PREVIEW" in page.stereo_bar.stereo_label.text()
        assert not page.stereo_bar.preview_button.isVisibleTo(page)
        # a stereo.yaml written later takes over from the preview
        from tests.app.virtual_inputs import true_stereo_yaml
        true_stereo_yaml(lab, page.state.project.path("stereo"))
        page.on_enter()
        assert page.model.stereo.kind == "file"
    finally:
        page.task.runner.shutdown()
        page.state.close()


def test_saved_and_verified_marker_counts_on_reopening(qtbot, page, lab):
    assert page.capture_training() and not page.train()       # busy: one task at a time
    wait(qtbot, page)
    assert page.train()
    wait(qtbot, page)
    assert page.next_pose()
    wait(qtbot, page)
    assert page.is_complete()
    again = MarkerPage(page.state, page.task.runner)
    qtbot.addWidget(again)
    again.on_enter()
    assert again.model.result.trained is not None and again.model.result.verified and again.is_complete()
    assert "already has a trained marker" in again.status.text()
    # without the verification record the saved marker is trained but not verified
    (page.state.project.folder / VERIFICATION_FILE).unlink()
    third = MarkerPage(page.state, page.task.runner)
    qtbot.addWidget(third)
    assert third.model.result.trained is not None and not third.is_complete()


def test_autopilot_trains_and_verifies(qtbot, page):
    outcome = []
    page.autopilot(lambda ok=True, message="": outcome.append((ok, message)))
    qtbot.waitUntil(lambda: bool(outcome), timeout=90000)
    ok, message = outcome[0]
    assert ok, message
    v = page.model.result.verification
    assert page.is_complete() and v.n == 10 and v.n_located >= 9
    assert "SIFT features" in message and "located" in message


def test_without_a_lab_the_page_asks_the_state_once_and_waits(qtbot, boxes):
    from app.state import WizardState

    state = WizardState(seed=0, noise=0.5)
    state.temporary_project()
    state.choose_preset("educational_6r")
    page = MarkerPage(state, TaskRunner())
    qtbot.addWidget(page)
    try:
        assert not state.labs.built
        assert page.capture_training()
        assert "Building the virtual lab" in page.status.text()
        assert not page.training_panel.capture_button.isEnabled()
        assert not page.compare_panel.compare_button.isEnabled()
        assert not page.compare()                       # one request at a time
        qtbot.waitUntil(lambda: page.model.result.training_image is not None, timeout=60000)
        wait(qtbot, page)
        assert state.labs.built and page.model.result.training_image.source == "virtual lab camera"
        assert page.training_panel.capture_button.isEnabled() and page.compare_panel.compare_button.isEnabled()
        assert boxes == []
    finally:
        page.task.runner.shutdown()
        state.close()
