"""The report's marker section, from marker.npz (the trained marker), marker_verification.json
(its last check) and marker_details.json (what the figures need: the last located live pair
with its crops, its SSD criteria curve and window sweep, and the last verification's per-pose
errors). Image positions in px, errors in mm.

marker_details.json: core/marker/details_file.py (MarkerDetails), written by the Marker page.
"""
from __future__ import annotations

import math

import numpy as np

from core.errors import RoboCalError
from core.files import read_json
from core.images import load_gray
from core.marker.correspondence import DEFAULT_MAX_RELIABILITY
from core.marker.details_file import DETAILS_FILE, MarkerDetails
from core.project import Project
from core.report.inputs import ReportInputs
from core.report.document import Figure, Section, esc, not_done, num, pairs_table, panel, series, unreadable

TITLE = "Marker"
MARKER_FILE = "marker.npz"
VERIFICATION_FILE = "marker_verification.json"
EDGE_DOTS = 48           # Canny edge pixels drawn per image (evenly spaced): more would hide the outline
ZOOM_PX = 8.0            # half-width of the "around the minimum" view of the criteria curve
MIN_DISPARITY_ERROR = 1e-3   # px: smaller disparity differences are drawn here (log axis)
NO_DETAILS = (f"the project holds no {DETAILS_FILE}; the Marker page writes it when a live pair is located "
              "and when a verification ends: locate a live pair and run a verification to add this figure")


def marker_section(inputs: ReportInputs, problems: list[str]) -> Section:
    project = inputs.project
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
        size=(500, 420)))
    details, why = _details(project, problems)
    blocks += _live(project, details.get("live"), why or "no live pair was located since the marker was trained",
                    problems)
    blocks += _verification(project, details.get("verification"), why, problems)
    return Section(TITLE, blocks)


def _details(project: Project, problems: list[str]) -> tuple[dict, str | None]:
    """marker_details.json's parts ({} when absent or unreadable) and why it is missing (None if read)."""
    path = project.folder / DETAILS_FILE
    if not path.is_file():
        return {}, NO_DETAILS
    try:
        details = MarkerDetails.read(path)
    except RoboCalError as exc:
        problems.append(f"{DETAILS_FILE}: {exc.message}")
        return {}, f"{DETAILS_FILE} cannot be read: {exc.message}"
    return details.to_dict(), None


def _message(exc: Exception) -> str:
    return exc.message if isinstance(exc, RoboCalError) else f"unexpected content ({type(exc).__name__}: {exc})"


def _bad(name: str, exc: Exception, problems: list[str]) -> str:
    """Record that `name` cannot be read (in `problems`) and say so."""
    problems.append(f"{name}: {_message(exc)}")
    return f"{name} cannot be read: {_message(exc)}"


# -- the live pair -----------------------------------------------------------------------------
LIVE_TITLES = {"marker_live": "Live pair: every stage of the detection",
               "marker_ssd": "SSD criteria along the epipolar line (chapter Fig. 16)",
               "marker_sweep": "Window-size sweep (chapter Fig. 17)"}


def _live(project: Project, live: dict | None, why: str, problems: list[str]) -> list:
    if live is None:
        return [Figure(key, title, "", unavailable=why) for key, title in LIVE_TITLES.items()]
    try:
        figures = [_live_figure(project, live), _ssd_figure(live.get("ssd")), _sweep_figure(live.get("sweep"))]
    except (RoboCalError, KeyError, TypeError, ValueError, IndexError) as exc:
        reason = _bad(DETAILS_FILE, exc, problems)
        return [Figure(key, title, "", unavailable=reason) for key, title in LIVE_TITLES.items()]
    text = ("<h3>Live pair</h3>" + pairs_table([
        ("pair", esc(live.get("pair"))),
        ("3D point (left camera frame)", _xyz(live.get("point_mm"), live.get("sigma_mm"))),
        ("error against the virtual lab's truth", num(live.get("error_mm"), 3, "mm")),
        ("disparity used", num(live.get("disparity_px"), 3, "px"))]))
    return [text] + figures


def _xyz(point, sigma) -> str:
    if point is None:
        return "—"
    sigma = sigma or [None] * 3
    return ", ".join(f"{a} = {num(p, 3)} ± {num(s, 3)}" for a, p, s in zip("xyz", point, sigma)) + " mm"


def _xy(points) -> tuple[list, list]:
    p = np.asarray(points if points else np.zeros((0, 2)), dtype=float).reshape(-1, 2)
    return p[:, 0].tolist(), p[:, 1].tolist()


def _closed(points) -> list:
    return list(points) + list(points[:1]) if points else []


def _box(roi) -> list:
    x0, y0, x1, y1 = roi
    return [[x0 - 0.5, y0 - 0.5], [x1 - 0.5, y0 - 0.5], [x1 - 0.5, y1 - 0.5], [x0 - 0.5, y1 - 0.5], [x0 - 0.5, y0 - 0.5]]


def _image_panel(project: Project, side: str, d: dict) -> dict:
    """One image of the pair, cropped, with the detection stages drawn in its pixels."""
    image, why = load_gray(project.folder / d["file"])
    if image is None:
        raise RoboCalError(f"cannot read the live pair's {side} crop: {why}", source=project.folder / d["file"])
    x0, y0 = (float(v) for v in d["origin"])
    s = float(d["scale"])

    def at(points) -> tuple[list, list]:          # image px -> crop drawing coordinates (pixel centres)
        x, y = _xy(points)
        return [(u - x0 + 0.5) * s for u in x], [(v - y0 + 0.5) * s for v in y]

    data = []
    sift, canny = d.get("sift") or {}, d.get("canny") or {}
    if canny.get("roi") and canny["roi"][2] > canny["roi"][0]:
        data.append(series("region of interest (Canny)", *at(_box(canny["roi"])), color=6, symbol="", line=True))
    if sift.get("outline"):
        data.append(series("homography outline (SIFT)", *at(_closed(sift["outline"])), color=5, symbol="",
                           line=True))
    edges = canny.get("edge_points") or []
    if edges:
        keep = np.linspace(0, len(edges) - 1, min(len(edges), EDGE_DOTS)).round().astype(int)
        data.append(series("Canny edge pixels (sides)", *at([edges[i] for i in keep]), color=0))
    if sift.get("agreeing_points"):
        data.append(series(f"SIFT matches that agree ({sift['agreeing']} of {sift['matches']})",
                           *at(sift["agreeing_points"]), color=2))
    if sift.get("other_points"):
        data.append(series("SIFT matches that do not", *at(sift["other_points"]), color=1, symbol="x"))
    if canny.get("fitted"):
        data.append(series("fitted outline", *at(_closed(canny["fitted"])), color=3, symbol="", line=True))
    if canny.get("reference"):
        data.append(series("reference point", *at([canny["reference"]]), color=4, symbol="+"))
    note = f"{side} camera" + (f", crop from ({x0:.0f}, {y0:.0f}) px" if x0 or y0 else "")
    if s < 0.999:
        note += f", ×{s:.2f}"
    return {**panel("image", note, "u (px, in the crop)", "v (px, in the crop)", data, equal_aspect=True),
            "image": image}


def _live_figure(project: Project, live: dict) -> Figure:
    images = live["images"]
    panels = [_image_panel(project, side, images[side]) for side in ("left", "right") if side in images]
    sides = []
    for side in ("left", "right"):
        d = images.get(side) or {}
        sift, canny = d.get("sift") or {}, d.get("canny") or {}
        if sift or canny:
            sides.append(f"{side}: {sift.get('agreeing', 0)} of {sift.get('matches', 0)} SIFT matches agree with "
                         f"the homography, reference point σ {num(canny.get('sigma_px'), 3)} px")
    return Figure(
        "marker_live", LIVE_TITLES["marker_live"],
        "Both images around the marker: SIFT matches (agreeing with the homography or not) and the outline the "
        "homography predicts; the region of interest where Canny runs and its edge pixels on the four sides "
        f"(every few drawn); the outline fitted to them and the reference point, the intersection of its "
        f"diagonals. {'; '.join(sides)}.", panels, size=(900, 560))


def _ssd_figure(ssd: dict | None) -> Figure:
    if ssd is None:
        return Figure("marker_ssd", LIVE_TITLES["marker_ssd"], "",
                      unavailable="the live pair had no SSD search (the marker was not found in the left image)")
    d = np.asarray(ssd["disparities"], dtype=float)
    c = np.asarray([np.nan if v is None else v for v in ssd["criteria"]], dtype=float)
    dm, cm = (np.nan if v is None else float(v) for v in ssd["minimum"])
    ylabel = "C(d) (grey level², per pixel)"

    def curves(sel, log: bool) -> list:
        keep = sel & np.isfinite(c) & ((c > 0) if log else True)
        out = [series("C(d), eq. (26)", d[keep], c[keep], color=0, symbol="", line=True)]
        if ssd.get("searched") is not None:
            w = np.asarray([np.nan if v is None else v for v in ssd["searched"]], dtype=float)
            ok = sel & np.isfinite(w) & ((w > 0) if log else True)
            out.append(series("searched (window pre-warped by the marker plane)", d[ok], w[ok], color=5,
                              symbol="", line=True))
        if math.isfinite(dm) and math.isfinite(cm) and (cm > 0 or not log):
            out.append(series(f"minimum d = {dm:.2f} px, eq. (27)", [dm], [cm], color=2))
        second = ssd.get("second")
        if second is not None and None not in second and (not log or second[1] > 0) and \
                sel[np.argmin(np.abs(d - second[0]))]:
            out.append(series("second-best minimum", [second[0]], [second[1]], color=1, symbol="t"))
        return out

    everything = np.ones(len(d), bool)
    near = np.abs(d - dm) <= ZOOM_PX if math.isfinite(dm) else everything
    h, w = ssd["window"]
    return Figure(
        "marker_ssd", LIVE_TITLES["marker_ssd"],
        f"The criteria function C(d) of a {w}×{h} px window (the marker's apparent size) on the left reference "
        "point, slid along the same row of the rectified right image: the whole search range (log scale) and "
        f"±{ZOOM_PX:.0f} px around its minimum. Sub-pixel disparity d* = {num(ssd.get('disparity'), 3)} px, "
        f"reliability {num(ssd.get('reliability'), 3)} (best / second-best minimum: 0 unique … 1 ambiguous).",
        [panel("points", "whole search range", "disparity d (px)", ylabel, curves(everything, True), log_y=True),
         panel("points", "around the minimum", "disparity d (px)", ylabel, curves(near, False))],
        size=(900, 360))


def _sweep_figure(sweep: dict | None) -> Figure:
    if sweep is None:
        return Figure("marker_sweep", LIVE_TITLES["marker_sweep"], "",
                      unavailable="the live pair had no window-size sweep (no left reference point)")

    def arr(key):
        return np.asarray([np.nan if v is None else v for v in sweep[key]], dtype=float)

    sizes, minima, disp, rel = arr("sizes"), arr("minima"), arr("disparities"), arr("reliabilities")
    located = sweep.get("located")
    if located is None:
        at = np.ones(len(sizes), bool)
        error = np.full(len(sizes), np.nan)
    else:
        error = np.abs(disp - float(located))
        at = np.isfinite(error) & (error <= 1.0)
    names = ("at d* (±1 px)", "elsewhere (wrong match)")

    def split(y, log=False):
        ok = np.isfinite(y)
        if log:
            y = np.maximum(y, MIN_DISPARITY_ERROR)
        return [series("all sizes", sizes[ok], y[ok], color=6, symbol="", line=True),
                series(names[0], sizes[ok & at], y[ok & at], color=2),
                series(names[1], sizes[ok & ~at], y[ok & ~at], color=1, symbol="x")]

    ticks = [int(s) for s in sizes[::2]]
    panels = [panel("points", "lowest criteria", "window side (px)", "lowest C (grey level², per pixel)",
                    split(minima), x_ticks=ticks)]
    if located is not None:
        panels.append(panel("points", "disparity error", "window side (px)",
                            "|d − d*| (px)", split(error, log=True), log_y=True, x_ticks=ticks))
    panels.append(panel("points", "reliability", "window side (px)", "best / second-best minimum",
                        split(rel), hlines=[(DEFAULT_MAX_RELIABILITY, f"accepted below {DEFAULT_MAX_RELIABILITY:g}")],
                        x_ticks=ticks))
    wrong = int(np.count_nonzero(~at & np.isfinite(minima)))
    return Figure(
        "marker_sweep", LIVE_TITLES["marker_sweep"],
        f"Square windows of {int(sizes.min())}…{int(sizes.max())} px at the left reference point: the lowest "
        "criteria grows with the window, which covers more of what differs between the two views; too small a "
        "window sees too little texture and may find its minimum elsewhere, a wrong match"
        + (f" ({wrong} of {len(sizes)} sizes here)" if wrong else " (none here)")
        + (f"; d* = {num(located, 3)} px is the disparity of the located pair" if located is not None else "")
        + f". Differences below {MIN_DISPARITY_ERROR:g} px are drawn at {MIN_DISPARITY_ERROR:g} px.",
        panels, size=(900, 340))


# -- the verification --------------------------------------------------------------------------
PRECISION_TITLE = "Verification: 3D error per pose"


def _verification(project: Project, details: dict | None, why: str | None, problems: list[str]) -> list:
    path = project.folder / VERIFICATION_FILE
    if not path.is_file():
        return ["<p class='grey'>The marker was not verified (no marker_verification.json).</p>",
                Figure("marker_precision", PRECISION_TITLE, "", unavailable="the marker was not verified")]
    try:
        v = read_json(path)
        if v.get("kind") == "live pair":
            title = "Last check: one live pair"
            rows = [("located", esc(v.get("located"))), ("3D error", num(v.get("error_mm"), 3, "mm"))]
        else:
            title = "Verification: located against known marker positions"
            rows = [("poses tried", esc(v["poses"])), ("located", f"{esc(v['located'])} "
                                                                  f"({num(100 * float(v['detection_rate']), 0)} %)"),
                    ("3D error, median", num(v.get("median_error_mm"), 3, "mm")),
                    ("3D error, RMS", num(v.get("rms_error_mm"), 3, "mm")),
                    ("3D error, max", num(v.get("max_error_mm"), 3, "mm")),
                    ("predicted σ (image noise), median", num(v.get("median_sigma_mm"), 3, "mm"))]
            if v.get("median_total_sigma_mm") is not None:
                rows.append(("predicted σ with the stereo calibration, median",
                             num(v.get("median_total_sigma_mm"), 3, "mm")))
        reasons = v.get("reasons") or {}
    except (RoboCalError, KeyError, TypeError, ValueError) as exc:
        reason = _bad(VERIFICATION_FILE, exc, problems)
        return [unreadable(VERIFICATION_FILE, _message(exc)), Figure("marker_precision", PRECISION_TITLE, "",
                                                                     unavailable=reason)]
    text = f"<h3>{esc(title)}</h3>" + pairs_table(rows)
    if v.get("kind") != "live pair":
        text += ("<p>The image-noise σ is the scatter of a point from one pair of images to the next with the "
                 "stereo calibration taken as exact; the calibration's own error (its focal lengths, principal "
                 "points, rotation and offset between the cameras) is one systematic error shared by every "
                 "point, and is not in it. "
                 + ("Propagated from the calibration's parameter covariance, it gives the σ with the stereo "
                    "calibration, the one the 3D error compares with.</p>"
                    if v.get("median_total_sigma_mm") is not None else
                    "The calibration's parameter covariance was not known for this verification.</p>"))
    if reasons:
        text += "<p>Not located: " + esc("; ".join(f"{k}: {n}" for k, n in reasons.items())) + "</p>"
    if details is None:
        figure = Figure("marker_precision", PRECISION_TITLE, "",
                        unavailable=why or "no verification was run since the marker was trained")
    else:
        try:
            figure = _precision_figure(details)
        except (KeyError, TypeError, ValueError) as exc:
            figure = Figure("marker_precision", PRECISION_TITLE, "", unavailable=_bad(DETAILS_FILE, exc, problems))
    return [text, figure]


def precision_numbers(details: dict) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per located pose: its number (from 1), the 3D error (mm), the predicted σ (mm)."""
    e = np.asarray([np.nan if x is None else x for x in details["errors_mm"]], dtype=float)
    s = np.asarray([np.nan if x is None else x for x in details["sigmas_mm"]], dtype=float)
    ok = np.isfinite(e)
    return np.flatnonzero(ok) + 1, e[ok], s[ok]


def _precision_figure(v: dict) -> Figure:
    pose, e, s = precision_numbers(v)
    if not len(e):
        return Figure("marker_precision", PRECISION_TITLE, "",
                      unavailable=f"the marker was located in none of the {v.get('poses')} poses")
    z = np.asarray([np.nan if x is None else x for x in v["depth_mm"]], dtype=float)[pose - 1]
    median, rms = float(np.median(e)), float(np.sqrt(np.mean(e ** 2)))
    names = ("error against the true position", "predicted σ of the 3D point")
    ticks = [int(p) for p in pose] if v["poses"] <= 25 else None

    def drawn(x, span) -> list:      # the points, then median and RMS across (in the legend: close values)
        return [series(names[0], x, e, color=0), series(names[1], x, s, color=4, symbol="t"),
                series(f"median {median:.3f} mm", span, [median] * 2, color=2, symbol="", line=True),
                series(f"RMS {rms:.3f} mm", span, [rms] * 2, color=1, symbol="", line=True)]
    return Figure(
        "marker_precision", PRECISION_TITLE,
        f"The marker located at {v['located']} of {v['poses']} random poses of the virtual lab: the 3D distance "
        "between the located and the true marker position (mm) per pose and against the marker's depth, beside "
        "the predicted standard deviation √(σx² + σy² + σz²), which grows with the depth squared. Stereo: "
        f"{v.get('stereo', '—')}.",
        [panel("points", "per pose", "pose", "3D distance (mm)", drawn(pose, [pose[0] - 0.5, pose[-1] + 0.5]),
               x_ticks=ticks),
         panel("points", "against the depth", "marker depth z (mm)", "3D distance (mm)",
               drawn(z, [np.nanmin(z), np.nanmax(z)]))],
        size=(900, 340))
