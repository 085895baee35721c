"""The report's marker section, from marker.npz (the trained marker) and
marker_verification.json (its last verification). Image positions in px, errors in mm."""
from __future__ import annotations

import numpy as np

from core.errors import RoboCalError
from core.files import read_json
from core.project import Project
from core.report.document import Figure, Section, esc, not_done, num, pairs_table, panel, series, unreadable

TITLE = "Marker"
MARKER_FILE = "marker.npz"
VERIFICATION_FILE = "marker_verification.json"


def marker_section(project: Project, facts: dict, problems: list[str]) -> Section:
    path = project.folder / MARKER_FILE
    if not path.is_file():
        return Section(TITLE, [not_done(f"no {MARKER_FILE} in the project")], done=False)
    try:
        from core.marker.training import TrainedMarker
        marker = TrainedMarker.load(path)
    except RoboCalError as exc:
        problems.append(f"{MARKER_FILE}: {exc.message}")
        return Section(TITLE, [unreadable(MARKER_FILE, exc.message)], done=False)
    w, h = marker.image_size
    facts["marker"] = marker.name
    blocks: list = [pairs_table([
        ("marker", esc(marker.name)),
        ("outer square", f"{num(marker.outer_size, 1)} mm, {num(marker.px_per_mm, 2)} px/mm in the training image"),
        ("training image", f"{w} × {h} px"),
        ("SIFT features", f"{marker.n_image_features} in the image, {marker.n_features} with the simulated "
                          "tilted views"),
        ("outline accuracy (predicted)", f"{num(marker.outline_sigma_px, 3)} px")])]
    outline = np.vstack([marker.outline, marker.outline[:1]])
    own = marker.keypoint_view == 0
    blocks.append(Figure(
        "marker_training", "Training image",
        "The marker's training image with the fitted outer square (orange) and the SIFT features found in it "
        "(blue); image coordinates in px, y down.",
        [{**panel("image", "", "u (px)", "v (px)",
                  [series("SIFT features", marker.keypoint_xy[own, 0], marker.keypoint_xy[own, 1], color=5),
                   series("outline", outline[:, 0], outline[:, 1], color=1, symbol="", line=True)],
                  equal_aspect=True), "image": marker.image}],
        size=(560, 480)))
    blocks += _verification(project, problems)
    return Section(TITLE, blocks)


def _verification(project: Project, problems: list[str]) -> list:
    path = project.folder / VERIFICATION_FILE
    if not path.is_file():
        return ["<p class='grey'>The marker was not verified (no marker_verification.json).</p>"]
    try:
        v = read_json(path)
        rows = [("poses tried", esc(v["poses"])), ("located", f"{esc(v['located'])} "
                                                             f"({num(100 * float(v['detection_rate']), 0)} %)"),
                ("3D error, median", num(v.get("median_error_mm"), 3, "mm")),
                ("3D error, RMS", num(v.get("rms_error_mm"), 3, "mm")),
                ("3D error, max", num(v.get("max_error_mm"), 3, "mm")),
                ("predicted σ, median", num(v.get("median_sigma_mm"), 3, "mm"))]
        reasons = v.get("reasons") or {}
    except (RoboCalError, KeyError, TypeError, ValueError) as exc:
        message = exc.message if isinstance(exc, RoboCalError) else f"unexpected content ({type(exc).__name__}: {exc})"
        problems.append(f"{VERIFICATION_FILE}: {message}")
        return [unreadable(VERIFICATION_FILE, message)]
    text = "<h3>Verification: located against known marker positions</h3>" + pairs_table(rows)
    if reasons:
        text += "<p>Not located: " + esc("; ".join(f"{k}: {n}" for k, n in reasons.items())) + "</p>"
    return [text]
