"""The report's stereo calibration section, from stereo.yaml and its details stereo.json
(per-pair errors, residuals, parameters with σ). Image errors in px, lengths in mm."""
from __future__ import annotations

import numpy as np

from core.errors import RoboCalError
from core.files import read_json
from core.project import Output, Project
from core.report.inputs import ReportInputs
from core.report.document import (Figure, Section, esc, not_done, num, pairs_table, panel, series, side_by_side, sig,
                                  unreadable)

TITLE = "Stereo calibration"
NO_DETAILS = ("the project has stereo.yaml but not its details stereo.json, which the Stereo calibration "
              "step saves with it; calibrate again to get this figure")


def cameras_summary(sf) -> str:
    """One line on the two cameras of the StereoFile `sf`, for the report's summary."""
    w, h = sf.image_size
    return (f"two cameras, {w} × {h} px, focal length {num(sf.K1[0, 0], 0)} / {num(sf.K2[0, 0], 0)} px, "
            f"baseline {num(sf.baseline_mm, 1)} mm")


def stereo_section(inputs: ReportInputs, problems: list[str]) -> Section:
    project, stereo = inputs.project, inputs.stereo
    if not stereo.present:
        return Section(TITLE, [not_done("no stereo.yaml in the project")], done=False)
    if stereo.error is not None:
        if not isinstance(stereo.error, RoboCalError):
            raise stereo.error
        problems.append(f"stereo.yaml: {stereo.error.message}")
        return Section(TITLE, [unreadable("stereo.yaml", stereo.error.message)], done=False)
    sf = stereo.value
    w, h = sf.image_size
    rows = [("image size", f"{w} × {h} px"),
            ("reprojection error, left camera", _rms(sf.rms_left)),
            ("reprojection error, right camera", _rms(sf.rms_right)),
            ("reprojection error, stereo", _rms(sf.rms_stereo)),
            ("baseline", f"{num(sf.baseline_mm, 2)} mm"),
            ("focal lengths (left)", f"{num(sf.K1[0, 0], 1)}, {num(sf.K1[1, 1], 1)} px"),
            ("focal lengths (right)", f"{num(sf.K2[0, 0], 1)}, {num(sf.K2[1, 1], 1)} px"),
            ("checkerboard", f"{sf.board.cols} × {sf.board.rows} inner corners, {num(sf.board.square, 2)} mm"
             if sf.board is not None else UNKNOWN)]
    if "epipolar_rms" in sf.extras:
        rows.append(("epipolar error after rectification", f"{num(sf.extras['epipolar_rms'])} px RMS"))
    if "cross_validation_px" in sf.extras:
        rows.append(("cross validation (pairs left out)", f"{num(sf.extras['cross_validation_px'])} px RMS"))
    blocks: list = [pairs_table(rows)]
    blocks += _details(project, problems, sf.rms_stereo)
    return Section(TITLE, blocks)


UNKNOWN = "unknown (not in the imported calibration)"


def _rms(value) -> str:
    """An RMS error (px), or unknown for a calibration imported without its statistics."""
    return UNKNOWN if value is None else f"{num(value)} px RMS"


def _details(project: Project, problems: list[str], rms_stereo: float) -> list:
    path = project.path(Output.STEREO_DETAILS)
    titles = ("Reprojection error per pair", "Corner residuals")
    if not path.is_file():
        return [Figure("stereo_pairs", titles[0], "", unavailable=NO_DETAILS),
                Figure("stereo_residuals", titles[1], "", unavailable=NO_DETAILS)]
    try:
        data = read_json(path)
        views = data["views"]
        pairs = [int(v["pair"]) for v in views]
        left = [float(v["rms_left"]) for v in views]
        right = [float(v["rms_right"]) for v in views]
        flagged = [v for v in views if v.get("outlier")]
        threshold = data.get("outlier_threshold_px")
        res_l = [np.asarray(v["residuals_left_px"], dtype=float).reshape(-1, 2) for v in views
                 if "residuals_left_px" in v]
        res_r = [np.asarray(v["residuals_right_px"], dtype=float).reshape(-1, 2) for v in views
                 if "residuals_right_px" in v]
        params = data.get("parameters") or []
    except (RoboCalError, KeyError, TypeError, ValueError) as exc:
        message = exc.message if isinstance(exc, RoboCalError) else f"unexpected content ({type(exc).__name__}: {exc})"
        problems.append(f"stereo.json: {message}")
        return [unreadable("stereo.json", message)]
    blocks: list = []
    hlines = [(threshold, f"drop threshold {num(threshold)} px")] if threshold is not None else []
    x = np.asarray(pairs, dtype=float)
    bars = [series("left camera", x - 0.2, left, color=0, bars=True),
            series("right camera", x + 0.2, right, color=1, bars=True)]
    caption = (f"RMS reprojection error of each checkerboard pair used ({len(pairs)} pairs), per camera. "
               + (f"A pair above the threshold ({num(threshold)} px) is flagged for removal"
                  + (f": pairs {', '.join(str(v['pair']) for v in flagged)}." if flagged else "; none is.")
                  if threshold is not None else ""))
    blocks.append(Figure("stereo_pairs", titles[0], caption,
                         [panel("points", "", "pair", "RMS reprojection error (px)", bars, hlines=hlines,
                                x_ticks=pairs)]))
    if res_l and res_r:
        L, R = np.concatenate(res_l), np.concatenate(res_r)
        blocks.append(Figure("stereo_residuals", titles[1],
                             f"Observed − projected position of every checkerboard corner ({len(L)} per camera), "
                             "in image pixels.",
                             [panel("points", "left camera", "residual u (px)", "residual v (px)",
                                    [series("left", L[:, 0], L[:, 1], color=0)], equal_aspect=True),
                              panel("points", "right camera", "residual u (px)", "residual v (px)",
                                    [series("right", R[:, 0], R[:, 1], color=1)], equal_aspect=True)],
                             size=(900, 380)))
    else:
        blocks.append(Figure("stereo_residuals", titles[1], "",
                             unavailable="stereo.json has no residuals (written by an older version)"))
    summary = data.get("calibration") if isinstance(data.get("calibration"), dict) else {}
    blocks.append(_coverage(summary.get("coverage")))
    blocks.append(_cross_validation(summary.get("cross_validation"), rms_stereo))
    if params:
        groups: dict[str, list] = {}
        for p in params:
            unit = f" {esc(p['unit'])}" if p.get("unit") else ""
            std = "fixed" if p.get("fixed") else ("" if p.get("std") is None else sig(p.get("std"), 2) + unit)
            groups.setdefault(str(p.get("group", "")), []).append(
                [esc(p.get("name", "")), num(p.get("value"), 4), std])
        # the left camera, right camera and stereo parameters side by side
        blocks.append("<h3>Camera parameters ± σ</h3>"
                      + side_by_side([[g, "value", "± σ"] for g in groups], list(groups.values()), numeric={1, 2}))
    return blocks


COVERAGE_BARS = (("X", "left–right"), ("Y", "up–down"), ("size", "near–far"), ("skew", "tilt"))


def _coverage(cov) -> Figure:
    title = "Coverage of the image by the checkerboard"
    if not isinstance(cov, dict):
        return Figure("stereo_coverage", title, "", unavailable="stereo.json does not record the coverage "
                                                                "(written by an older version)")
    values = [float(cov[k]) for k, _ in COVERAGE_BARS]
    verdict = ("Enough varied views." if cov.get("enough") else
               "Not enough varied views: " + "; ".join(str(a) for a in cov.get("advice") or []) + ".")
    return Figure(
        "stereo_coverage", title,
        f"How much of the possible range the {cov.get('pairs', '?')} accepted pairs span (ROS camera_calibration's "
        "measures, worse camera of the two; 1 = the full range): position left–right (X) and up–down (Y) in "
        "the image, size (distance) and skew (tilt). " + verdict,
        [panel("points", "", "measure", "coverage (0–1)",
               [series("coverage", range(len(values)), values, color=0, bars=True)],
               hlines=[(1.0, "full range")], x_ticks=[(i, f"{k} ({what})") for i, (k, what) in
                                                     enumerate(COVERAGE_BARS)])],
        size=(900, 300))


def _cross_validation(cv, rms_stereo) -> Figure:
    title = "Cross-validation: two halves of the pairs calibrated alone"
    if not isinstance(cv, dict):
        return Figure("stereo_cross_validation", title, "",
                      unavailable="stereo.json does not record a cross-validation (too few pairs to split, or "
                                  "written by an older version)")
    bars = [("observed area", cv["rms_observed_px"]), ("whole image", cv["rms_px"]),
            ("left camera, whole image", cv["left_rms_px"]), ("right camera, whole image", cv["right_rms_px"])]
    hlines = [(float(rms_stereo), f"stereo reprojection error {num(rms_stereo)} px")] if rms_stereo else []
    return Figure(
        "stereo_cross_validation", title,
        f"The pairs were split {cv.get('split', 'in two')} and each half calibrated alone; the bars (RMS) are "
        "how far apart (px) the two models project the same ray: where the boards were (the headline "
        "figure: about the corner noise when the calibration is sound), RMS over the whole image and per "
        f"camera (extrapolation); the largest difference is {num(cv.get('max_px'), 2)} px. The halves' baselines "
        "differ by "
        f"{num(cv.get('baseline_diff_mm'), 3)} mm and their rotations by {num(cv.get('rotation_diff_deg'), 3)}°.",
        [panel("points", "", "", "model difference (px)",
               [series("difference of the two halves' models", range(len(bars)), [float(v) for _, v in bars],
                       color=2, bars=True)],
               hlines=hlines, x_ticks=[(i, name) for i, (name, _) in enumerate(bars)])],
        size=(900, 300))
