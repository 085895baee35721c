"""The report's marker section: the live pair with every detection stage, the SSD criteria
curve (Fig. 16), the window sweep (Fig. 17) and the verification precision plot drawn from
marker_details.json with the project's numbers; a project without it (or with a bad one) says
what is missing; a last check by a live pair is reported, not called unreadable."""
from __future__ import annotations

import json

import cv2
import numpy as np
import pytest

from core.files import atomic_write_json
from core.marker.training import train_marker
from core.project import create_project, open_project
from core.report import build_report
from core.marker.details_file import DETAILS_FILE, DETAILS_FORMAT, LIVE_IMAGES
from core.report.marker import MIN_DISPARITY_ERROR, VERIFICATION_FILE

LIVE_KEYS = ["marker_live", "marker_ssd", "marker_sweep"]
ERRORS = [0.012, None, 0.020, 0.031, 0.008]           # mm per pose; pose 2 not located


@pytest.fixture(scope="module")
def trained(built_lab):
    image = built_lab(seed=0, noise=0.5).render_training_image()
    return train_marker(image, outer_size=60.0, tilted_views=False)


def marker_project(folder, trained):
    project = create_project(folder, name="marker")
    (project.folder / "marker.npz").write_bytes(trained.to_bytes())
    atomic_write_json(project.folder / VERIFICATION_FILE,
                      {"format": "robocal.marker_verification/1", "marker": "marker.npz", "kind": "verification",
                       "poses": 5, "located": 4, "detection_rate": 0.8, "median_error_mm": 0.016,
                       "rms_error_mm": 0.0196, "max_error_mm": 0.031, "median_sigma_mm": 0.01,
                       "reasons": {"too few SIFT matches": 1}})
    return project


def side(origin, scale=1.0) -> dict:
    return {"file": "", "origin": origin, "scale": scale, "image_size": [1280, 1024], "found": True, "reason": "",
            "sift": {"mode": "roi", "matches": 40, "agreeing": 3, "agreeing_points": [[510, 410], [520, 415],
                                                                                       [530, 420]],
                     "other_points": [[560, 470]], "outline": [[500, 400], [580, 400], [580, 480], [500, 480]],
                     "reference": [540, 440], "roi": [490, 390, 590, 490]},
            "canny": {"ok": True, "roi": [490, 390, 590, 490], "edge_points": [[500, 400 + i] for i in range(80)],
                      "fitted": [[500.2, 400.1], [580.1, 400.3], [579.9, 480], [500, 479.8]],
                      "corners": [[500.2, 400.1], [580.1, 400.3], [579.9, 480], [500, 479.8]],
                      "reference": [540.25, 440.5], "sigma_px": 0.02}}


def details() -> dict:
    d = np.arange(20.0, 80.0)
    criteria = 40 + (d - 50.3) ** 2
    return {"format": DETAILS_FORMAT, "marker": "marker.npz",
            "live": {"pair": 1, "error_mm": 0.011, "point_mm": [10.0, -5.0, 700.0], "sigma_mm": [0.01, 0.01, 0.05],
                     "disparity_px": 50.31, "images": {"left": side([450, 350]), "right": side([400, 350], 0.5)},
                     "ssd": {"window": [61, 63], "disparities": d.tolist(), "criteria": criteria.tolist(),
                             "searched": None, "minimum": [50.3, 40.09], "second": [70.0, 428.0], "disparity": 50.31,
                             "reliability": 0.1},
                     "sweep": {"sizes": [5, 7, 9, 11], "minima": [3.0, 5.0, 7.0, 9.0],
                               "disparities": [20.0, 50.30, 50.315, 50.31], "reliabilities": [0.9, 0.5, 0.3, 0.2],
                               "located": 50.31}},
            "verification": {"poses": 5, "located": 4, "stereo": "stereo.yaml", "depth_mm": [600, 650, 700, 750, 800],
                             "errors_mm": ERRORS, "sigmas_mm": [0.01, None, 0.012, 0.014, 0.016],
                             "median_error_mm": 0.016, "rms_error_mm": 0.0196}}


def write_details(project, data) -> None:
    for name in ("left", "right"):
        data["live"]["images"][name]["file"] = LIVE_IMAGES[name]
        cv2.imwrite(str(project.folder / LIVE_IMAGES[name]), np.full((140, 150), 128, np.uint8))
    (project.folder / DETAILS_FILE).write_text(json.dumps(data))


def figures(project) -> tuple[dict, list]:
    report = build_report(open_project(project.folder))
    marker = next(s for s in report.sections if s.title == "Marker")
    return {f.key: f for f in marker.figures()}, report.problems


def by_name(panel) -> dict:
    return {s["name"]: s for s in panel["series"]}


def test_the_figures_hold_the_details_numbers(tmp_path, trained):
    project = marker_project(tmp_path / "p", trained)
    write_details(project, details())
    figs, problems = figures(project)
    assert problems == []
    for key in LIVE_KEYS + ["marker_training", "marker_precision"]:
        assert figs[key].unavailable is None and figs[key].panels, key
    # the pair: both crops, the stages in crop pixels (image px − origin + ½, times the scale)
    left, right = figs["marker_live"].panels
    assert left["kind"] == right["kind"] == "image" and left["image"].shape == (140, 150)
    ref = by_name(left)["reference point"]
    assert (ref["x"], ref["y"]) == ([540.25 - 450 + 0.5], [440.5 - 350 + 0.5])
    ref = by_name(right)["reference point"]
    assert (ref["x"], ref["y"]) == ([(540.25 - 400 + 0.5) * 0.5], [(440.5 - 350 + 0.5) * 0.5])
    names = set(by_name(left))
    assert {"SIFT matches that agree (3 of 40)", "SIFT matches that do not", "homography outline (SIFT)",
            "region of interest (Canny)", "Canny edge pixels (sides)", "fitted outline"} <= names
    assert len(by_name(left)["fitted outline"]["x"]) == 5                      # closed
    # Fig. 16: the curve, its minimum; the zoom keeps ±8 px around it
    whole, near = figs["marker_ssd"].panels
    assert whole["log_y"] and "disparity" in whole["xlabel"] and "(px)" in whole["xlabel"]
    assert "grey level²" in whole["ylabel"]
    curve = by_name(whole)["C(d), eq. (26)"]
    assert curve["x"] == list(np.arange(20.0, 80.0)) and min(curve["y"]) == pytest.approx(40.09)
    assert by_name(whole)["minimum d = 50.30 px, eq. (27)"]["y"] == [40.09]
    assert "second-best minimum" in by_name(whole) and "second-best minimum" not in by_name(near)
    assert min(by_name(near)["C(d), eq. (26)"]["x"]) == 43 and max(by_name(near)["C(d), eq. (26)"]["x"]) == 58
    # Fig. 17: the 5 px window found its minimum elsewhere; disparity error and reliability per size
    lowest, error, reliability = figs["marker_sweep"].panels
    assert by_name(lowest)["elsewhere (wrong match)"]["x"] == [5]
    assert by_name(lowest)["at d* (±1 px)"]["y"] == [5.0, 7.0, 9.0]
    assert lowest["xlabel"] == "window side (px)" and error["ylabel"] == "|d − d*| (px)" and error["log_y"]
    errs = by_name(error)["all sizes"]["y"]
    assert errs[0] == pytest.approx(30.31) and errs[3] == MIN_DISPARITY_ERROR and errs[2] == pytest.approx(0.005)
    assert by_name(reliability)["all sizes"]["y"] == [0.9, 0.5, 0.3, 0.2]
    assert "1 of 4 sizes" in figs["marker_sweep"].caption
    # the precision plot: located poses only, median and RMS lines of these errors
    per_pose, depth = figs["marker_precision"].panels
    e = by_name(per_pose)["error against the true position"]
    assert e["x"] == [1, 3, 4, 5] and e["y"] == [0.012, 0.020, 0.031, 0.008]
    located = np.array([0.012, 0.020, 0.031, 0.008])
    median, rms = float(np.median(located)), float(np.sqrt(np.mean(located ** 2)))
    lines = by_name(per_pose)
    assert lines[f"median {median:.3f} mm"]["y"] == pytest.approx([median] * 2)
    assert lines[f"RMS {rms:.3f} mm"]["y"] == pytest.approx([rms] * 2) and lines[f"RMS {rms:.3f} mm"]["x"] == [0.5, 5.5]
    assert per_pose["ylabel"] == "3D distance (mm)" and depth["xlabel"] == "marker depth z (mm)"
    assert by_name(depth)["error against the true position"]["x"] == [600, 700, 750, 800]


def test_a_project_without_details_says_what_is_missing(tmp_path, trained):
    project = marker_project(tmp_path / "p", trained)
    figs, problems = figures(project)
    assert problems == [] and figs["marker_training"].unavailable is None
    for key in LIVE_KEYS + ["marker_precision"]:
        assert DETAILS_FILE in figs[key].unavailable and "locate a live pair" in figs[key].unavailable, key


def test_details_without_a_verification_or_of_another_format(tmp_path, trained):
    project = marker_project(tmp_path / "p", trained)
    data = details()
    del data["verification"]
    write_details(project, data)
    figs, problems = figures(project)
    assert problems == [] and figs["marker_live"].unavailable is None
    assert figs["marker_precision"].unavailable == "no verification was run since the marker was trained"
    (project.folder / DETAILS_FILE).write_text(json.dumps({**data, "format": "robocal.marker_details/9"}))
    figs, problems = figures(project)
    assert len(problems) == 1 and problems[0].startswith(f"{DETAILS_FILE}: {project.folder / DETAILS_FILE}: ")
    assert f"field 'format': format 'robocal.marker_details/9', expected '{DETAILS_FORMAT}'" in problems[0]
    assert all("robocal.marker_details/9" in figs[k].unavailable for k in LIVE_KEYS)
    (project.folder / LIVE_IMAGES["left"]).unlink()
    write_details(project, details())
    (project.folder / LIVE_IMAGES["right"]).write_bytes(b"not a png")
    figs, problems = figures(project)
    assert len(problems) == 1 and "right crop" in problems[0]
    assert figs["marker_precision"].unavailable is None


def test_a_live_pair_as_last_check_is_reported(tmp_path, trained):
    project = marker_project(tmp_path / "p", trained)
    atomic_write_json(project.folder / VERIFICATION_FILE, {"format": "robocal.marker_verification/1",
                                                           "marker": "marker.npz", "kind": "live pair",
                                                           "poses": 1, "located": 1, "error_mm": 0.0123})
    report = build_report(open_project(project.folder))
    marker = next(s for s in report.sections if s.title == "Marker")
    text = "".join(b for b in marker.blocks if isinstance(b, str))
    assert report.problems == [] and "Last check: one live pair" in text and "0.012 mm" in text


def test_the_verification_gives_both_sigmas_and_says_why_they_differ(tmp_path, trained):
    project = marker_project(tmp_path / "p", trained)
    record = json.loads((project.folder / VERIFICATION_FILE).read_text())
    marker = next(s for s in build_report(open_project(project.folder)).sections if s.title == "Marker")
    text = "".join(b for b in marker.blocks if isinstance(b, str))
    assert "predicted σ (image noise), median" in text and "with the stereo calibration, median" not in text
    assert "is not in it" in text and "covariance was not known" in text
    record.update(median_calibration_sigma_mm=0.115, median_total_sigma_mm=0.1154)
    atomic_write_json(project.folder / VERIFICATION_FILE, record)
    marker = next(s for s in build_report(open_project(project.folder)).sections if s.title == "Marker")
    text = "".join(b for b in marker.blocks if isinstance(b, str))
    assert "predicted σ with the stereo calibration, median" in text and "0.115 mm" in text
    assert "the one the 3D error compares with" in text
