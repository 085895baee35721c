"""The Marker step's work with plain arguments on a real virtual lab (built once per module):
the training image, training on a crop, one live pair, the verification and its statistics,
rejection reasons counted together, the marker comparison, and the step's project files."""
from __future__ import annotations

import json
import math
from collections import Counter

import cv2
import numpy as np
import pytest

from app.jobs.marker import (VerificationResult, capture_training_image, crop_around, details_file, live_pair,
                             load_training_image, recorded_verification, run_comparison, run_verification,
                             save_trained, short_reason, stereo_parameter_covariance, train_job,
                             write_verification)
from app.pages.measurement_inputs import (MARKER_FILE, TRAINING_FILE, VERIFICATION_FILE, preview_source,
                                          verification_file)
from core.errors import Cancelled, RoboCalError
from core.marker.location import LocatorOptions, MarkerLocator
from core.marker.training import TrainedMarker
from core.marker.details_file import LIVE_IMAGES
from core.project import create_project
from core.robot.simulated import SimulatedRobot


@pytest.fixture(scope="module")
def lab(built_lab):
    return built_lab(None, 0, 0.5)                     # the educational 6R arm


@pytest.fixture(scope="module")
def captured(lab):
    return capture_training_image(lab)


@pytest.fixture(scope="module")
def trained(captured):
    return train_job(captured.image, None, captured.outer_size, captured.source).trained


@pytest.fixture(scope="module")
def locator(lab, trained):
    return MarkerLocator(trained, preview_source(lab).rect, LocatorOptions())


def test_capture_finds_the_outline_and_the_lab_marker_size(lab):
    steps = []
    image = capture_training_image(lab, progress=lambda f, m: steps.append(m))
    assert image.image.shape == (480, 480) and image.image.dtype == np.uint8
    assert image.outline is not None and image.outline.shape == (4, 2) and image.outline_problem == ""
    assert image.outer_size == pytest.approx(lab.marker.outer_size)
    assert image.source == "virtual lab camera"
    assert "taking the training image" in steps


def test_load_training_image_reads_a_file_and_names_a_bad_one(tmp_path, captured):
    path = tmp_path / "marker.png"
    cv2.imwrite(str(path), captured.image)
    image = load_training_image(path)
    assert np.array_equal(image.image, captured.image) and image.source == str(path)
    assert np.allclose(image.outline, captured.outline) and image.outer_size is None
    blank = tmp_path / "blank.png"
    cv2.imwrite(str(blank), np.full((200, 200), 200, np.uint8))
    nothing = load_training_image(blank)
    assert nothing.outline is None and nothing.outline_problem
    broken = tmp_path / "broken.png"
    broken.write_text("not an image")
    with pytest.raises(RoboCalError) as err:
        load_training_image(broken)
    assert "cannot read the image" in err.value.message and "broken.png" in str(err.value)


def test_crop_around_adds_the_margin_inside_the_image():
    square = np.array([[100, 100], [200, 100], [200, 200], [100, 200]], float)
    assert crop_around(square, 300, 250) == (82, 82, 218, 218)
    assert crop_around(square - 95, 150, 120) == (0, 0, 123, 120)


def test_train_job_on_a_crop_keeps_its_offset(captured):
    training = train_job(captured.image, (100, 100, 380, 380), captured.outer_size, "test")
    t = training.trained
    assert t.image.shape == (280, 280) and training.box == (100, 100, 380, 380)
    assert np.allclose(training.offset, [100, 100])
    assert np.allclose(t.reference_px + training.offset, [239.5, 239.5], atol=0.2)


def test_live_pair_locates_the_marker_and_moves_the_robot(lab, locator):
    driver = SimulatedRobot(lab.true_robot)
    driver.connect()
    live = live_pair(lab, locator, 1, 0, driver)
    assert live.location.ok, live.location.reason
    assert np.allclose(driver.current_joints(), live.q)
    assert np.allclose(live.truth, lab.marker_position(live.q))
    assert live.error < 0.05                           # the true rig: a few thousandths of a mm
    assert live.sweep is not None and list(live.sweep.sizes) == list(range(5, 38, 2))
    again = live_pair(lab, locator, 1, 0)              # same seed and index: same pose
    assert np.array_equal(again.q, live.q)


def test_verification_compares_every_pose_with_the_truth(lab, locator):
    v = run_verification(lab, locator, 3, 0, 1, "preview")
    assert v.n == 3 and v.n_located >= 2 and v.median_error < 0.05
    assert np.all(np.isfinite(v.depth)) and np.all(np.isfinite(v.errors[v.located]))
    assert sum(v.reasons.values()) == v.n - v.n_located
    d = v.to_dict()
    assert d["poses"] == 3 and d["located"] == v.n_located and d["stereo"] == "preview"
    with pytest.raises(Cancelled):
        run_verification(lab, locator, 3, 0, 1, "preview", cancelled=lambda: True)


def test_verification_statistics_skip_what_was_not_located():
    nan = float("nan")
    v = VerificationResult(4, "s", np.full(4, 500.0), np.array([1.0, 2.0, nan, 9.0]),
                           np.array([0.1, 0.3, nan, nan]), np.array([True, True, False, False]),
                           Counter({"outline not found": 2}))
    assert v.n_located == 2 and v.detection_rate == 0.5
    assert v.median_error == 1.5 and v.max_error == 2.0
    assert v.rms_error == pytest.approx(math.sqrt(2.5)) and v.median_sigma == pytest.approx(0.2)
    d = v.to_dict()
    assert d["rms_error_mm"] == pytest.approx(math.sqrt(2.5), abs=1e-6)
    assert d["reasons"] == {"outline not found": 2}
    empty = VerificationResult(2, "s", np.full(2, nan), np.full(2, nan), np.full(2, nan), np.zeros(2, bool))
    assert math.isnan(empty.median_error) and empty.to_dict()["median_error_mm"] is None


def test_short_reason_counts_alike_reasons_together():
    a = short_reason("only 12 of 40 SIFT matches agree (ratio 0.30)")
    b = short_reason("only 7 of 33 SIFT matches agree (ratio 0.21)")
    assert a == b == "only # of # SIFT matches agree"
    assert short_reason("edge fit: -1.5 px off") == "edge fit: # px off"
    assert short_reason("") == "no reason given"
    assert len(short_reason("x " * 200)) == 110


def test_comparison_trains_every_candidate_on_the_same_views(lab):
    comparison = run_comparison(lab, 1, 0)
    result = comparison.result
    keys = {p.key for p in result.patterns}
    assert result.views == 1 and len(result.patterns) == 5 and result.recommended in keys
    assert comparison.images and set(comparison.images) <= keys
    assert all(img.shape == (64, 64) for img in comparison.images.values())


def test_project_files_of_the_step(tmp_path, trained):
    project = create_project(tmp_path / "project")
    write_verification(project, "old.npz", {"located": 3})
    old_details = [details_file(project)] + [project.folder / name for name in LIVE_IMAGES.values()]
    for old in old_details:
        old.write_bytes(b"of the old marker")
    assert recorded_verification(project)
    path = save_trained(project, trained)
    assert not any(old.exists() for old in old_details)
    assert path == project.folder / MARKER_FILE
    assert TrainedMarker.load(path).n_features == trained.n_features
    assert cv2.imread(str(project.folder / TRAINING_FILE), cv2.IMREAD_GRAYSCALE).shape == trained.image.shape
    assert not (project.folder / VERIFICATION_FILE).exists()        # it was of the old marker
    assert not recorded_verification(project)
    write_verification(project, path.name, {"kind": "live pair", "located": 0})
    assert not recorded_verification(project)
    write_verification(project, path.name, {"kind": "live pair", "located": 1})
    assert recorded_verification(project)
    verification_file(project).write_text("{ not json")
    assert not recorded_verification(project)


def test_project_files_held_by_a_running_command_are_not_written(tmp_path, trained):
    import os

    from core.errors import RoboCalError
    from core.locks import output_lock

    project = create_project(tmp_path / "project")
    (project.folder / TRAINING_FILE).write_bytes(b"previous")
    with output_lock(project.folder / MARKER_FILE), pytest.raises(RoboCalError) as info:
        save_trained(project, trained)
    assert f"being written by process {os.getpid()}" in str(info.value)
    assert (project.folder / TRAINING_FILE).read_bytes() == b"previous"        # both files, or neither
    assert not (project.folder / MARKER_FILE).exists()
    with output_lock(verification_file(project)), pytest.raises(RoboCalError, match="being written"):
        write_verification(project, MARKER_FILE, {"located": 1})
    assert save_trained(project, trained) == project.folder / MARKER_FILE


def _lab_calibration(lab):
    """A StereoFile of the lab's true cameras (as a calibration would give them)."""
    from core.stereo.file import StereoFile

    rig = lab.rig
    size = (rig.left.width, rig.left.height)
    R1, R2, P1, P2, Q, *_ = cv2.stereoRectify(rig.left.K, rig.left.dist, rig.right.K, rig.right.dist, size,
                                              rig.R, rig.T.reshape(3, 1), flags=cv2.CALIB_ZERO_DISPARITY, alpha=0)
    return StereoFile(size, rig.left.K, rig.left.dist, rig.right.K, rig.right.dist, rig.R, rig.T,
                      rig.essential(), rig.fundamental(), R1, R2, P1, P2, Q)


def test_verification_adds_the_stereo_calibrations_share_of_sigma(lab, trained):
    from core.stereo.point_uncertainty import PARAMETERS
    from core.stereo.rectification import StereoRectification

    calibration = _lab_calibration(lab)
    locator = MarkerLocator(trained, StereoRectification.from_calibration(calibration), LocatorOptions())
    cov = np.diag([0.1 ** 2] * 8 + [0.005 ** 2] * 3 + [0.01 ** 2] * 3)      # px², deg², mm²
    assert cov.shape == (len(PARAMETERS),) * 2
    v = run_verification(lab, locator, 3, 0, 1, "stereo.yaml", None, cov)
    located = v.located
    assert located.sum() >= 2
    assert np.all(np.isfinite(v.calibration_sigmas[located])) and np.all(np.isnan(v.calibration_sigmas[~located]))
    assert np.all(v.calibration_sigmas[located] > v.sigmas[located])       # 0.1 px of focal length: tenths of a mm
    assert v.median_total_sigma == pytest.approx(np.median(np.hypot(v.sigmas, v.calibration_sigmas)[located]))
    assert v.to_dict()["median_total_sigma_mm"] == pytest.approx(v.median_total_sigma, abs=1e-6)
    plain = run_verification(lab, locator, 3, 0, 1, "stereo.yaml")          # no covariance known
    assert plain.calibration_sigmas is None and math.isnan(plain.median_total_sigma)
    assert plain.to_dict()["median_total_sigma_mm"] is None


def test_the_covariance_comes_from_stereo_json_or_the_result_of_this_calibration(lab, tmp_path):
    from types import SimpleNamespace

    from core.stereo.point_uncertainty import PARAMETERS

    calibration = _lab_calibration(lab)
    cov = np.eye(len(PARAMETERS)) * 0.01
    rows = [{"group": g, "name": "fx", "value": float(k[0, 0]), "std": 0.1}
            for g, k in (("left", calibration.K1), ("right", calibration.K2))]
    rows += [{"group": "stereo", "name": n, "value": float(t), "std": 0.1} for n, t in zip("tx ty tz".split(),
                                                                                       calibration.T)]
    details = tmp_path / "stereo.json"
    details.write_text(json.dumps({"parameters": rows, "parameter_covariance": {
        "names": list(PARAMETERS), "units": "px, deg, mm", "matrix": cov.tolist()}}))
    np.testing.assert_array_equal(stereo_parameter_covariance(calibration, details), cov)
    same = SimpleNamespace(file=calibration, covariance=2 * cov)
    np.testing.assert_array_equal(stereo_parameter_covariance(calibration, tmp_path / "none.json", same), 2 * cov)
    moved = _lab_calibration(lab)
    moved.T = moved.T + np.array([0.5, 0.0, 0.0])
    other = SimpleNamespace(file=moved, covariance=2 * cov)                 # another calibration in memory
    assert stereo_parameter_covariance(calibration, None, other) is None
    assert stereo_parameter_covariance(None, details, same) is None
