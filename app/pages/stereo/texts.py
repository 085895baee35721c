"""The Stereo page's words: badges, what each figure means, the summary and residual tables
(Qt rich text), the parameter table's names, tool tips."""
from __future__ import annotations

import numpy as np

from app.html import esc, number
from core.stereo.calibration import StereoCalibrationResult

VIRTUAL_TOOLTIP = ("The virtual lab's cameras see its checkerboard at well-spread poses; the images are "
                   "saved into the project (checkerboard/left, checkerboard/right)")
CAMERA_TOOLTIP_HARDWARE = ("Open the two cameras on the Setup page first (or add pairs from folders); each "
                           "capture is saved into the project (checkerboard/left, checkerboard/right).")
CAMERA_TOOLTIP_VIRTUAL = ("Virtual lab: take one pair with the lab's two cameras, the board held at a random "
                          "pose. With cameras opened on the Setup page, the pair comes from them.")
CAMERA_TOOLTIP_LIVE = ("Save the pair the live view shows into the project (checkerboard/left, "
                       "checkerboard/right, numbered); hold the board still, in view of both cameras.")
CAMERA_TOOLTIP_NO_BOARD = ("Hold the board in view of both cameras: a capture is possible once the live view "
                           "says board seen for the left and the right camera.")
BAR_TIPS = {"X": "Spread of the board's horizontal position over the images (ROS camera_calibration's X)",
            "Y": "Spread of the board's vertical position over the images (ROS's Y)",
            "size": "How large the board appears, up to filling the images (ROS's size)",
            "skew": "How much the board is tilted towards and away from the cameras (ROS's skew)"}


def short_reason(reason: str | None) -> str:
    """A few words for a thumbnail badge (the tool tip has the whole reason)."""
    if not reason:
        return "rejected"
    r = reason.lower()
    for key, text in (("too similar", "too similar"), ("blurred", "blurred"), ("partial board", "partial board"),
                      ("not reliable", "corners unreliable"), ("size mismatch", "size mismatch"),
                      ("differs from the other", "other image size"), ("turned", "left/right order"),
                      ("truncated", "unreadable"), ("not a readable", "unreadable"), ("empty file", "unreadable"),
                      ("not found", "board not found"), ("cannot read", "unreadable")):
        if key in r:
            return text
    return reason[:28]



def rms_meaning(v: float) -> str:
    if v < 0.25:
        return "excellent: the model fits every corner to a small fraction of a pixel"
    if v < 0.5:
        return "good: typical of sharp images and a flat board"
    if v < 1.0:
        return "acceptable: look at the pairs with the highest bars (blur, motion, a bent board)"
    return ("poor: check the square size, blurred or moving boards and misdetected pairs "
            "(the highest bars first)")


def epipolar_meaning(rms: float, mx: float) -> str:
    if rms < 0.3 and mx < 1.5:
        return ("matching corners lie on the same row after rectification: a stereo match can be searched "
                "along the row")
    if rms < 1.0:
        return "small vertical offsets remain: usable, but check that the cameras did not move during capture"
    return "large vertical offsets: the cameras moved between pairs, or some pairs are wrong"


def cross_validation_meaning(v: float) -> str:
    if v < 0.5:
        return "the two halves agree — the model is well determined"
    if v < 2.0:
        return ("the two halves differ noticeably: add pairs, especially near the image edges and with "
                "the board tilted")
    return ("the two halves disagree: the model is poorly determined — add pairs with more coverage and "
            "tilt, or use fewer distortion coefficients")


def summary_html(r: StereoCalibrationResult) -> str:
    """The summary figures of a calibration, each with a one-line interpretation."""
    cv = r.cross_validation
    b_std = r.std.get("baseline", float("nan"))
    rows = [
        ("Reprojection RMS, left", number(r.file.rms_left, 3, "px"), rms_meaning(r.file.rms_left)),
        ("Reprojection RMS, right", number(r.file.rms_right, 3, "px"), rms_meaning(r.file.rms_right)),
        ("Reprojection RMS, stereo", number(r.file.rms_stereo, 3, "px"),
         rms_meaning(r.file.rms_stereo) + " (all corners of both cameras in the joint fit)"),
        ("Epipolar error after rectification",
         f"{number(r.epipolar_rms, 3, 'px')} RMS, {number(r.epipolar_max, 3, 'px')} max",
         epipolar_meaning(r.epipolar_rms, r.epipolar_max)),
    ]
    if cv is not None:
        rows.append(("Cross-validation (two halves)", number(cv.rms_observed_px, 3, "px"),
                     cross_validation_meaning(cv.rms_observed_px)
                     + f" (RMS where the boards were; up to {cv.max_px:.2g} px where no board reached). "
                       f"Their baselines differ by {cv.baseline_diff_mm:.3f} mm"))
    else:
        rows.append(("Cross-validation (two halves)", "not computed",
                     "needs at least 8 pairs: the model's stability is unknown"))
    rows.append(("Baseline |T|", f"{r.baseline_mm:.3f} ± {b_std:.2g} mm",
                 "the distance between the two optical centres: compare it with a ruler between the lenses"))
    out = ['<table cellspacing="0" cellpadding="3">']
    for label, value, meaning in rows:
        out.append(f'<tr><td valign="top"><b>{esc(label)}</b>&nbsp;&nbsp;</td>'
                   f'<td valign="top" style="white-space:nowrap">{esc(value)}&nbsp;&nbsp;</td>'
                   f'<td valign="top" style="color:#3c4043">{esc(meaning)}</td></tr>')
    out.append("</table>")
    used = (f"<p>{r.pairs_used} pairs used, {len(r.rejected)} rejected by detection, {len(r.excluded)} "
            f"dropped by you. Model: {esc(r.options.describe())}.</p>")
    out.append(used)
    if r.warnings:
        out.append("<p><b>Warnings</b></p><ul>" + "".join(f"<li>{esc(w)}</li>" for w in r.warnings) + "</ul>")
    return "".join(out)


def residual_stats_html(r: StereoCalibrationResult) -> str:
    """RMS of the residuals along x and y, mean (bias) and largest, per camera (px)."""
    cols = []
    for res in (r.fit.residuals_left, r.fit.residuals_right):
        e = res.reshape(-1, 2)
        e = e[np.all(np.isfinite(e), axis=1)]
        if not len(e):
            cols.append(["—"] * 5)
            continue
        rms = np.sqrt(np.mean(e ** 2, axis=0))
        mean = np.round(e.mean(axis=0), 3) + 0.0      # no "-0.000"
        worst = float(np.max(np.hypot(e[:, 0], e[:, 1])))
        cols.append([f"{rms[0]:.3f}", f"{rms[1]:.3f}", f"{mean[0]:+.3f}", f"{mean[1]:+.3f}", f"{worst:.3f}"])
    names = ["RMS x", "RMS y", "mean x", "mean y", "largest"]
    rows = "".join(f"<tr><td>{n}</td><td align='right'>{a}</td><td align='right'>{b}</td></tr>"
                   for n, a, b in zip(names, *cols))
    return ("<table cellspacing='0' cellpadding='2'><tr><th align='left'>px</th><th align='right'>left</th>"
            "<th align='right'>&nbsp;right</th></tr>" + rows + "</table>"
            "<p style='color:#5f6368'>The means should be close to 0 (no bias) and RMS x close to RMS y. "
            "The largest is usually 3–4× the RMS; much more points to one bad corner or pair "
            "(see Errors per pair).</p>")


PARAM_NAMES = {"fx": "fx (focal length)", "fy": "fy (focal length)", "cx": "cx (principal point)",
               "cy": "cy (principal point)", "k1": "k1 (radial)", "k2": "k2 (radial)", "k3": "k3 (radial)",
               "k4": "k4 (rational)", "k5": "k5 (rational)", "k6": "k6 (rational)", "p1": "p1 (tangential)",
               "p2": "p2 (tangential)", "rx": "R: rx (rotation vector)", "ry": "R: ry (rotation vector)",
               "rz": "R: rz (rotation vector)", "tx": "T: tx", "ty": "T: ty", "tz": "T: tz",
               "baseline": "baseline |T|"}
GROUP_NAMES = {"left": "Left camera", "right": "Right camera", "stereo": "Right from left"}
UNIT_NAMES = {"deg": "°"}


def pairs_status(items, result_stale: bool, note: str = "") -> tuple[str, bool | None]:
    """The status line after pairs were added or removed: how many, which were rejected and why
    (the first three), `note`, and whether a calibration must be made again; with its colour
    (None: neutral, False: some rejected)."""
    total = len(items)
    rejected = [a.detection for a in items if not a.detection.accepted]
    text = f"{total} pair{'s' if total != 1 else ''} on the page"
    if rejected:
        shown = "; ".join(f"pair {d.index + 1}: {d.reason}" for d in rejected[:3])
        text += f"; {len(rejected)} rejected ({shown}{'; …' if len(rejected) > 3 else ''})"
    text += "." + note
    if result_stale:
        text += " Pairs changed since the calibration: calibrate again."
    return text, None if not rejected else False
