"""The Stereo calibration page driven end to end with pytest-qt: pairs from the virtual lab,
from folders and from the (virtual) cameras; calibrate on the worker thread; drop a pair by
moving the threshold line; save stereo.yaml and export; Cancel; bad folders; autopilot."""
from __future__ import annotations

import json
import shutil
import threading

import cv2
import numpy as np
import pytest
from PySide6.QtCore import Qt
from PySide6.QtWidgets import QFileDialog

from app.jobs import stereo_pairs
from app.jobs.stereo_pairs import FILE_CHUNK
from app.pages.stereo import page as stereo_page
from app.pages.stereo.page import StereoPage
from app.pages.stereo.results_panel import PREVIEW_GAP
from app.state import WizardState
from app.worker import TaskRunner
from core.stereo.board import Board
from core.project import HARDWARE
from core.stereo.file import read_stereo_yaml
from core.virtual_lab.lab import VirtualLab
from tests.core.stereo_synth import REAL_DATA, real_pairs

WAIT_MS = 90000


@pytest.fixture(scope="module")
def lab(built_lab):
    """One virtual lab for the whole file (a copy of the session's)."""
    return built_lab(seed=0)


@pytest.fixture
def shared_lab(lab, monkeypatch):
    """The page builds its lab with VirtualLab.create: hand it the module's lab."""
    monkeypatch.setattr(VirtualLab, "create", classmethod(lambda cls, *a, **kw: lab))
    return lab


@pytest.fixture(scope="module")
def rendered_folders(lab, tmp_path_factory):
    """8 virtual-lab pairs written as PNGs into left/ and right/ (like `robocal simulate`)."""
    root = tmp_path_factory.mktemp("rendered")
    poses = lab.random_board_poses(8, np.random.default_rng(5))
    for side in ("left", "right"):
        (root / side).mkdir()
    for i, pose in enumerate(poses):
        left, right = lab.render_checkerboard_pair(pose, np.random.default_rng([5, i]))
        cv2.imwrite(str(root / "left" / f"img_{i:02d}.png"), left)
        cv2.imwrite(str(root / "right" / f"img_{i:02d}.png"), right)
    return root


def make_page(qtbot, tmp_path, mode=None):
    state, tasks = WizardState(), TaskRunner()
    if mode is None:
        state.new_project(tmp_path / "project")
    else:
        state.new_project(tmp_path / "project", mode=mode)
    page = StereoPage(state, tasks)
    qtbot.addWidget(page)
    page.resize(1100, 900)
    page.show()
    return page


@pytest.fixture
def page(qtbot, tmp_path, shared_lab):
    p = make_page(qtbot, tmp_path)
    yield p
    p.task.runner.shutdown()
    p.state.close()


def wait(qtbot, page, timeout=WAIT_MS):
    qtbot.waitUntil(lambda: not page.task.busy, timeout=timeout)


def patch_dirs(monkeypatch, *answers):
    answers = list(map(str, answers))
    monkeypatch.setattr(QFileDialog, "getExistingDirectory", lambda *a, **kw: answers.pop(0))


# -- the whole walk ------------------------------------------------------------------------
def test_virtual_lab_pairs_calibrate_drop_outlier_and_export(page, qtbot, tmp_path, monkeypatch):
    assert page.board == Board(9, 6, 25.0)                      # prefilled from the lab
    assert not page.options_panel.calibrate_button.isEnabled() and not page.save_button.isEnabled()
    page.pairs.virtual_count.setValue(12)
    qtbot.mouseClick(page.pairs.virtual_button, Qt.MouseButton.LeftButton)
    assert page.task.busy and page.task.progress_row().cancel_button.isEnabled()
    wait(qtbot, page)
    assert len(page.items) == 12 and page.pairs.strip.count() == 12
    folder = page.state.project.folder / "checkerboard"
    assert len(list((folder / "left").glob("pair_*.png"))) == 12
    assert len(list((folder / "right").glob("pair_*.png"))) == 12
    accepted = len(page.usable_pairs())
    assert accepted >= 10
    assert all(v > 0 for v in page.pairs.coverage_bars.values().values())
    assert "12 pairs" in page.pairs.count_label.text()
    assert page.options_panel.calibrate_button.isEnabled()

    qtbot.mouseClick(page.options_panel.calibrate_button, Qt.MouseButton.LeftButton)
    wait(qtbot, page)
    r = page.result
    assert r is not None and r.pairs_used == accepted and r.file.rms_stereo < 0.2
    series = page.results.errors_chart.series()
    assert len(series["pairs"]) == accepted
    assert page.results.errors_chart.selected() == []                    # the line starts above every bar
    assert page.results.table.find("left", "fx") >= 0 and "±" in page.results.table.cell_text(page.results.table.find("left", "fx"), 3)
    assert page.results.table.find("stereo", "baseline") >= 0
    summary = page.results.summary_view.toPlainText()
    assert "Cross-validation" in summary and "Epipolar" in summary and "the model" in summary
    h, w = r.file.image_size[1], r.file.image_size[0]
    qtbot.waitUntil(lambda: len(page.results.preview.image_shape()) > 0, timeout=WAIT_MS)   # rectified on a worker
    assert page.results.preview.image_shape()[:2] == (h, 2 * w + PREVIEW_GAP)
    assert "Epipolar error of this pair" in page.results.preview_caption.text()
    assert page.results.scatter.counts() == (accepted * 54, accepted * 54)
    assert "✓" in page.pairs.strip.caption(page.items[0].key) and "px" in page.pairs.strip.caption(page.items[0].key)

    # drag the threshold just below the highest bar: that pair is selected, then dropped
    worst = np.maximum(series["left"], series["right"])
    order = np.argsort(worst)
    page.results.errors_chart.set_threshold((worst[order[-1]] + worst[order[-2]]) / 2)
    assert page.results.errors_chart.selected() == [int(order[-1])]
    dropped_pair = int(series["pairs"][order[-1]]) - 1
    assert page.results_actions.selected_pairs() == [dropped_pair]
    assert page.results.drop_button.isEnabled()
    qtbot.mouseClick(page.results.drop_button, Qt.MouseButton.LeftButton)
    wait(qtbot, page)
    assert page.result is not r and page.result.pairs_used == accepted - 1
    assert page.result.excluded == [dropped_pair]
    dropped = next(a for a in page.items if a.detection.index == dropped_pair)
    assert page.pairs.strip.badge(dropped.key) == "dropped by you"
    assert page.results.restore_button.isEnabled()

    assert not page.is_complete()
    with qtbot.waitSignal(page.completeChanged):
        qtbot.mouseClick(page.save_button, Qt.MouseButton.LeftButton)
    path = page.state.project.path("stereo")
    sf = read_stereo_yaml(path)
    assert sf.image_size == r.file.image_size and sf.board == page.board
    assert abs(sf.rms_stereo - page.result.file.rms_stereo) < 1e-9
    assert page.is_complete() and page.state.stereo is page.result

    patch_dirs(monkeypatch, tmp_path / "ros")
    qtbot.mouseClick(page.ros_button, Qt.MouseButton.LeftButton)
    assert (tmp_path / "ros" / "left.yaml").is_file() and (tmp_path / "ros" / "right.yaml").is_file()
    assert "camera_matrix" in (tmp_path / "ros" / "left.yaml").read_text()
    monkeypatch.setattr(QFileDialog, "getSaveFileName", lambda *a, **kw: (str(tmp_path / "out.json"), "JSON"))
    qtbot.mouseClick(page.json_button, Qt.MouseButton.LeftButton)
    data = json.loads((tmp_path / "out.json").read_text())
    assert data["calibration"]["pairs_used"] == accepted - 1 and len(data["views"]) == accepted - 1


def test_capture_takes_one_virtual_pair(page, qtbot):
    assert page.pairs.capture_button.isEnabled()
    assert "virtual lab" in page.pairs.capture_button.toolTip().lower()
    qtbot.mouseClick(page.pairs.capture_button, Qt.MouseButton.LeftButton)
    wait(qtbot, page)
    qtbot.mouseClick(page.pairs.capture_button, Qt.MouseButton.LeftButton)
    wait(qtbot, page)
    assert len(page.items) == 2
    assert {a.source for a in page.items} == {"virtual camera"}
    names = sorted(p.name for p in (page.state.project.folder / "checkerboard" / "left").iterdir())
    assert names == ["pair_000.png", "pair_001.png"]


def test_capture_is_disabled_for_hardware_until_cameras_are_opened(qtbot, tmp_path):
    page = make_page(qtbot, tmp_path, mode=HARDWARE)
    try:
        assert not page.pairs.capture_button.isEnabled() and not page.pairs.virtual_button.isEnabled()
        assert "Open the two cameras on the Setup page" in page.pairs.capture_button.toolTip()
        assert page.pairs.folders_button.isEnabled()
        assert page.board == Board(9, 6, 24.0)
    finally:
        page.task.runner.shutdown()
        page.state.close()


# -- folders ----------------------------------------------------------------------------------
def test_one_folder_of_left_and_right_images_asks_once(page, qtbot, monkeypatch, rendered_folders, tmp_path):
    mixed = tmp_path / "mixed"
    mixed.mkdir()
    for i in range(8):
        shutil.copy(rendered_folders / "left" / f"img_{i:02d}.png", mixed / f"left{i + 1:02d}.png")
        shutil.copy(rendered_folders / "right" / f"img_{i:02d}.png", mixed / f"right{i + 1:02d}.png")
    patch_dirs(monkeypatch, mixed)                # one answer: a second dialog would find none
    qtbot.mouseClick(page.pairs.folders_button, Qt.MouseButton.LeftButton)
    wait(qtbot, page)
    assert len(page.items) == 8 and len(page.usable_pairs()) == 8
    assert page.items[0].detection.name == "left01.png | right01.png"
    (mixed / "right08.png").unlink()
    patch_dirs(monkeypatch, mixed)
    assert not page.sources.add_folders_dialog()
    assert "left08.png has no partner" in page.status.text()


def test_add_folders_then_change_the_board(page, qtbot, monkeypatch, rendered_folders):
    patch_dirs(monkeypatch, rendered_folders / "left", rendered_folders / "right")
    qtbot.mouseClick(page.pairs.folders_button, Qt.MouseButton.LeftButton)
    wait(qtbot, page)
    assert len(page.items) == 8 and len(page.usable_pairs()) == 8
    assert page.items[0].detection.name == "img_00.png | img_00.png"
    assert page.options_panel.calibrate_button.isEnabled()

    # a wrong board size: every pair is detected again and rejected with the reason shown
    page.pairs.cols_spin.setValue(8)
    page.apply_board()
    wait(qtbot, page)
    assert len(page.items) == 8 and page.usable_pairs() == []
    assert page.pairs.strip.badge(page.items[0].key) == "board not found"
    assert "8x6" in page.pairs.strip.tooltip(page.items[0].key)
    assert not page.options_panel.calibrate_button.isEnabled()
    assert "rejected" in page.status.text()

    page.pairs.cols_spin.setValue(9)
    page.apply_board()
    wait(qtbot, page)
    assert len(page.usable_pairs()) == 8 and page.pairs.strip.badge(page.items[0].key) is None
    assert {a.source for a in page.items} == {"folders"}
    assert page.calibrate()
    wait(qtbot, page)
    assert page.result is not None and page.result.pairs_used == 8
    # 8 pairs are not enough views: calibrated, with the warning in the summary
    assert "not enough views" in page.results.summary_view.toPlainText()


def test_adding_folders_is_one_job_whose_batches_fill_the_strip(page, qtbot, rendered_folders):
    """8 pairs, detected FILE_CHUNK at a time in one worker job: each batch is on the page while
    that job still runs (the same task handle), the last one before it ends."""
    seen = []
    page.model.on("added", lambda added: seen.append((len(added), len(page.items), page.task.handle)))
    assert page.sources.add_folders(rendered_folders / "left", rendered_folders / "right")
    handle = page.task.handle
    wait(qtbot, page)
    assert [(n, total) for n, total, _ in seen] == [(FILE_CHUNK, FILE_CHUNK), (8 - FILE_CHUNK, 8)]
    assert handle is not None and all(h is handle for _, _, h in seen)
    assert page.pairs.strip.count() == 8 and page.status.text() == "8 pairs on the page."


def test_another_project_drops_the_batches_still_coming(page, qtbot, rendered_folders, tmp_path, monkeypatch):
    """A batch handed over by the worker but not yet on the page when the project changes never
    arrives there."""
    first_handed_over, go_on = threading.Event(), threading.Event()
    detect = stereo_pairs.detect_files

    def detect_after_the_first_batch(*args, **kwargs):
        if kwargs["first"] > 0:                  # the first batch went to the GUI thread (queued)
            first_handed_over.set()
            go_on.wait(WAIT_MS / 1000)
        return detect(*args, **kwargs)
    monkeypatch.setattr(stereo_pairs, "detect_files", detect_after_the_first_batch)
    assert page.sources.add_folders(rendered_folders / "left", rendered_folders / "right")
    assert first_handed_over.wait(WAIT_MS / 1000) and page.items == []
    page.state.new_project(tmp_path / "other")
    go_on.set()
    assert page.task.runner.wait(WAIT_MS)
    assert page.items == [] and page.pairs.strip.count() == 0 and page.model.detections is None


@pytest.mark.skipif(not REAL_DATA.is_dir(), reason=f"real checkerboard pairs not found at {REAL_DATA}")
def test_real_pairs_flagged_outlier_dropped(qtbot, tmp_path, monkeypatch):
    page = make_page(qtbot, tmp_path, mode=HARDWARE)
    try:
        left, right = tmp_path / "L", tmp_path / "R"
        left.mkdir()
        right.mkdir()
        for a, b in real_pairs():
            shutil.copy(a, left / a.name)
            shutil.copy(b, right / b.name)
        page.sources.set_board(Board(9, 6, 24.0))
        assert page.sources.add_folders(left, right)
        wait(qtbot, page)
        assert len(page.usable_pairs()) == 25
        assert page.calibrate()
        wait(qtbot, page)
        r = page.result
        assert r.outliers, "the real data set has a flagged pair"
        assert page.results.flagged_button.isEnabled()
        assert any(page.results.errors_chart.series()["flagged"])
        page.results_actions.select_flagged()
        assert set(r.outliers) <= set(page.results_actions.selected_pairs())
        n = len(page.results_actions.selected_pairs())
        assert page.results_actions.drop_selected()
        wait(qtbot, page)
        assert page.result.pairs_used == 25 - n
        assert abs(page.result.file.K1[0, 0] / 518.05 - 1) < 0.02
    finally:
        page.task.runner.shutdown()
        page.state.close()


def test_bad_folders_give_a_clear_message(page, qtbot, tmp_path, rendered_folders):
    left, right = tmp_path / "left", tmp_path / "right"
    shutil.copytree(rendered_folders / "left", left)
    shutil.copytree(rendered_folders / "right", right)
    (left / "img_08.png").write_bytes((left / "img_00.png").read_bytes())
    assert not page.sources.add_folders(left, right)                # unequal counts: nothing starts
    assert not page.task.busy and page.items == []
    text = page.status.text()
    assert "9 left images" in text and "8 right images" in text and "img_08.png" in text

    # a non-image file is ignored (and said so); a truncated image is a rejected pair
    (left / "img_08.png").unlink()
    (left / "notes.txt").write_text("taken on Monday")
    for side in (left, right):
        for name in [f"img_{i:02d}.png" for i in range(2, 8)]:
            (side / name).unlink()
    data = (right / "img_01.png").read_bytes()
    (right / "img_01.png").write_bytes(data[: len(data) // 2])
    assert page.sources.add_folders(left, right)
    wait(qtbot, page)
    assert len(page.items) == 2
    assert "notes.txt" in page.status.text()
    bad = page.items[1]
    assert not bad.detection.accepted and page.pairs.strip.badge(bad.key) == "unreadable"
    assert "truncated PNG" in page.pairs.strip.tooltip(bad.key)
    assert "rejected" in page.status.text()


# -- cancel -------------------------------------------------------------------------------------
@pytest.mark.no_session_cache          # the rendering must still be under way when it is cancelled
def test_cancel_rendering_keeps_finished_pairs_only(page, qtbot):
    page.sources.add_virtual_pairs(12)
    qtbot.waitUntil(lambda: len(page.items) >= 1 or not page.task.busy, timeout=WAIT_MS)
    page.task.cancel()
    wait(qtbot, page)
    assert "Cancelled" in page.status.text()
    assert 1 <= len(page.items) < 12
    left = page.state.project.folder / "checkerboard" / "left"
    assert len(list(left.glob("*.png"))) == len(page.items)     # a cancelled batch leaves no files
    assert not list(left.glob(".*"))                           # nor temporary ones


def test_cancel_calibration(page, qtbot, monkeypatch, rendered_folders):
    assert page.sources.add_folders(rendered_folders / "left", rendered_folders / "right")
    wait(qtbot, page)
    assert page.calibrate()
    page.task.cancel()
    wait(qtbot, page)
    assert page.result is None and "Cancelled" in page.status.text()
    assert page.options_panel.calibrate_button.isEnabled() and not page.save_button.isEnabled()


# -- autopilot and a project that has a calibration -------------------------------------------------
def test_autopilot_renders_calibrates_and_saves(page, qtbot, monkeypatch):
    monkeypatch.setattr(stereo_page, "VIRTUAL_PAIRS", 12)
    done = []
    page.autopilot(lambda ok=True, message="": done.append((ok, message)))
    qtbot.waitUntil(lambda: bool(done), timeout=WAIT_MS)
    assert done[0][0], done
    assert "stereo RMS" in done[0][1]
    assert page.is_complete() and page.state.project.has("stereo")

    # the same project opened again: the step is already done
    other = WizardState()
    other.open_project(page.state.project.folder)
    again = StereoPage(other, page.task.runner)
    qtbot.addWidget(again)
    assert again.is_complete()                        # done at once, from stereo.yaml
    qtbot.waitUntil(lambda: not again.task.busy, timeout=WAIT_MS)
    assert "already has stereo.yaml" in again.status.text() and "saved pairs are back" in again.status.text()
    assert len(again.items) == 12                     # the pairs rendered into the project
    assert again.is_complete()
    other.close()


def test_autopilot_without_pairs_in_a_hardware_project_fails_clearly(qtbot, tmp_path):
    page = make_page(qtbot, tmp_path, mode=HARDWARE)
    try:
        done = []
        page.autopilot(lambda ok=True, message="": done.append((ok, message)))
        assert done == [(False, "no checkerboard pairs: add pairs from folders first")]
    finally:
        page.task.runner.shutdown()
        page.state.close()


# -- swapped cameras -----------------------------------------------------------------------
@pytest.mark.skipif(not REAL_DATA.is_dir(), reason=f"real checkerboard pairs not found at {REAL_DATA}")
def test_swapped_real_pairs_are_swapped_on_the_spot(page, qtbot, monkeypatch, tmp_path):
    """The published real pairs are given to the wrong cameras: the page says so and one button
    calibrates them the other way round."""
    folder = tmp_path / "real"
    folder.mkdir()
    for a, b in real_pairs([1, 3, 5, 8, 11, 13, 17, 19, 22, 24]):
        shutil.copy(a, folder / a.name)
        shutil.copy(b, folder / b.name)
    page.pairs.cols_spin.setValue(9)
    page.pairs.rows_spin.setValue(6)
    page.pairs.square_spin.setValue(24.0)
    page.apply_board()
    patch_dirs(monkeypatch, folder)
    qtbot.mouseClick(page.pairs.folders_button, Qt.MouseButton.LeftButton)
    wait(qtbot, page)
    assert page.calibrate()
    wait(qtbot, page)
    before = page.result
    assert before.cameras_look_swapped and page.swap_button.isVisible()
    assert "Swap left and right" in page.status.text()
    qtbot.mouseClick(page.swap_button, Qt.MouseButton.LeftButton)
    qtbot.waitUntil(lambda: page.result is not None and not page.task.busy, timeout=WAIT_MS)
    after = page.result
    assert not after.cameras_look_swapped and not page.swap_button.isVisible()
    assert page.items[0].detection.name == "right01.jpg | left01.jpg"
    assert after.pairs_used == before.pairs_used
    assert after.baseline_mm == pytest.approx(before.baseline_mm, rel=0.01)
    assert -after.file.T[0] > 0.9 * after.baseline_mm        # the right camera now on the right (x > 0)
    assert "Left and right images swapped" in page.status.text()


def test_swapping_pairs_saved_in_the_project_swaps_their_folders(qtbot, tmp_path, shared_lab, monkeypatch,
                                                                   rendered_folders):
    project = tmp_path / "project"
    saved = project / "checkerboard"
    shutil.copytree(rendered_folders / "left", saved / "right")        # saved the wrong way round
    shutil.copytree(rendered_folders / "right", saved / "left")
    page = make_page(qtbot, tmp_path)
    try:
        wait(qtbot, page)
        assert len(page.items) == 8
        assert page.calibrate()
        wait(qtbot, page)
        assert page.result.cameras_look_swapped
        first_right = (saved / "right" / "img_00.png").read_bytes()
        assert page.sources.swap_cameras()
        qtbot.waitUntil(lambda: page.result is not None and not page.task.busy, timeout=WAIT_MS)
        assert not page.result.cameras_look_swapped
        assert (saved / "left" / "img_00.png").read_bytes() == first_right
        assert (saved / "left" / "img_00.png").read_bytes() == (rendered_folders / "left" / "img_00.png").read_bytes()
        assert page.items[0].detection.name == "img_00.png | img_00.png"
    finally:
        page.task.runner.shutdown()
        page.state.close()
