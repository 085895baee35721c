"""The Identification page's words: the measurements line, the summary, the validation and
accuracy report (all errors in mm)."""
from __future__ import annotations

from pathlib import Path

from app.html import esc, number
from app.jobs.identification import IdentificationRun
from app.lab import DEFAULT_POSES, DEFAULT_SIGMA_MM

SYNTHETIC = "#8a4b00"


def stats_rows(rows: list[tuple[str, object]]) -> str:
    """A table of error statistics (mean, RMS, max in mm, points), one row per (label, stats)."""
    out = ['<table cellspacing="0" cellpadding="3" border="0">',
           '<tr><th align="left"></th><th align="right">mean</th><th align="right">RMS</th>'
           '<th align="right">max</th><th align="right">points</th></tr>']
    for label, s in rows:
        out.append(f'<tr><td>{esc(label)}&nbsp;&nbsp;</td><td align="right">{number(s.mean_mm)}</td>'
                   f'<td align="right"><b>{number(s.rms_mm)}</b></td><td align="right">{number(s.max_mm)}</td>'
                   f'<td align="right">{s.n}</td></tr>')
    out.append("</table>")
    return "".join(out)


def _validation_part(r) -> list[str]:
    v = r.validation
    if v is None:
        return ["<h3>Validation</h3><p>No poses were left out: choose a hold-out fraction or k-fold "
                "cross validation to check the model on poses the fit did not see.</p>"]
    if v.method == "holdout":
        how = (f"{len(v.test_poses)} held-out poses ({v.fraction:.0%} of {r.n_poses + len(v.test_poses)}, "
               f"seed {v.seed}) that the fit did not see")
    else:
        how = (f"{v.folds}-fold cross validation: each of the {len(v.test_poses)} poses predicted by a model "
               f"fitted without it (seed {v.seed})")
    parts = [f"<h3>Validation on poses left out of the fit (mm)</h3><p>{esc(how)}.</p>",
             stats_rows([("before (nominal, base registered)", v.before), ("after (calibrated)", v.after)])]
    if v.fold_rms_mm:
        parts.append("<p>RMS per fold: " + ", ".join(f"{x:.3f}" for x in v.fold_rms_mm) + " mm</p>")
    return parts


def _accuracy_part(a) -> list[str]:
    return [f"<h3>Real accuracy: against the virtual lab's true robot (mm)</h3>"
            f"<p>Marker position of each model vs. the true robot at {a.n_configurations} fresh "
            f"random visible poses (not measured): what the calibration really gained, "
            f"{a.improvement:.0f}× more accurate. Compared after the best rigid alignment of "
            f"the frames: the measured camera frame is off the true one by the stereo "
            f"calibration's own error (without alignment the calibrated model is "
            f"{a.calibrated.raw_rms_mm:.3f} mm RMS off).</p>",
            stats_rows([("nominal model (base registered)", a.nominal), ("calibrated model", a.calibrated)])]


def _fit_part(r) -> list[str]:
    obs = r.observability
    parts = [f"<h3>Fitted poses (mm)</h3><p>{r.n_poses} poses, {r.n_points} points.</p>",
             stats_rows([("before (nominal, base registered)", r.before), ("after (calibrated)", r.after)]),
             "<h3>Fit</h3><ul>"
             f"<li>{r.n_iterations} iterations, {'converged' if r.converged else 'NOT converged'}; "
             f"estimated σ = {r.sigma_hat_text} ({r.dof} degrees of freedom)</li>"
             f"<li>{len(r.estimated)} parameters estimated, rank {r.rank}; "
             f"condition number κ = {r.condition_number:.4g} of the column-scaled Φ</li>"
             f"<li>observability O1 = {obs.o1:.3g}, O2 = 1/κ = {obs.o2:.3g}, O3 = σ<sub>min</sub> = {obs.o3:.3g}</li>"
             f"<li>{len(r.unidentifiable)} parameters not identifiable (kept at nominal)"
             + (f"; {len(r.outliers)} outlier point(s), Huber k = {r.huber:g}" if r.huber else "")
             + "</li></ul>"]
    if r.prior is not None:
        parts += _prior_part(r.prior)
    parts += _deflection_part(r)
    if r.orientation is not None:
        parts += _orientation_part(r.orientation)
    if r.warnings:
        parts.append("<h3>Warnings</h3><ul>" + "".join(f"<li>{esc(w)}</li>" for w in r.warnings) + "</ul>")
    return parts


def _orientation_part(o) -> list[str]:
    held = (f"; {o.holdout_rms_after_deg:.4f}° on the poses left out" if o.holdout_rms_after_deg is not None else "")
    only = (f" Determined only thanks to the orientation: {esc(', '.join(o.determined))}." if o.determined
            else " No robot parameter is determined by the orientation alone here.")
    return [f"<h3>Marker orientation</h3><p>{o.n_points} points with a measured orientation: RMS "
            f"{o.rms_before_deg:.4f}° before, {o.rms_after_deg:.4f}° after{held}.{only}</p>"]


def _deflection_part(r) -> list[str]:
    """The deflection choice in plain words, and the payload the calibration was measured with."""
    c = r.compliance
    payload = ("" if r.payload_kg is None else f" Payload during the measurements: {r.payload_kg:g} kg"
               + (" — the deflection terms hold for this payload." if c is not None and c.kept else "."))
    if c is None or (c.mode == "off" and not payload):
        return []
    return [f"<h3>Deflection under the arm's weight</h3><p>{esc(c.verdict)}{esc(payload)}</p>"]


def _prior_part(p) -> list[str]:
    if not p.weights.geometric:
        return [f"<h3>Prior toward nominal</h3><p>Weight 0 ({esc(p.chosen_by)}): no pull toward the nominal "
                "values, so the fit is the plain one.</p>"]
    dominated = ", ".join(p.dominated) or "none"
    return [f"<h3>Prior toward nominal</h3><p>Weight {esc(p.weight_text)} ({esc(p.chosen_by)}): a DH length may move "
            f"about {number(p.std_length_mm, 3, 'mm')} and an angle about {p.std_angle_deg:.3g}° from nominal "
            f"before the pull outweighs the measurements. Decided mostly by the prior (data share below 0.5): "
            f"{esc(dominated)}.</p>"]


def validation_html(run: IdentificationRun) -> str:
    """Validation, real accuracy, fit statistics and warnings as HTML (all in mm)."""
    r = run.result
    parts = _validation_part(r)
    if run.accuracy is not None:
        parts += _accuracy_part(run.accuracy)
    return "".join(parts + _fit_part(r))


def summary_text(run: IdentificationRun) -> str:
    """One paragraph: RMS before → after on the fitted poses, the poses left out, the true robot."""
    r = run.result
    text = (f"RMS position error {r.before.rms_mm:.3f} → <b>{r.after.rms_mm:.3f} mm</b> on {r.n_poses} fitted poses")
    if r.validation is not None:
        text += (f"; on poses left out: {r.validation.before.rms_mm:.3f} → "
                 f"<b>{r.validation.after.rms_mm:.3f} mm</b>")
    if run.accuracy is not None:
        text += (f"; against the true robot: {run.accuracy.nominal.rms_mm:.3f} → "
                 f"<b>{run.accuracy.calibrated.rms_mm:.3f} mm</b>")
    text += (f". {len(r.estimated)} parameters estimated (rank {r.rank}, κ = {r.condition_number:.3g}), "
             f"{len(r.unidentifiable)} not identifiable, {r.n_iterations} iterations.")
    return text


NO_PROJECT = "<b>No project or robot model yet.</b> Choose them in the Setup step (1)."


def missing_html(path: Path, virtual: bool) -> str:
    """No measurements file: run the Measurement step (or, in the virtual lab, use ideal ones)."""
    text = (f"<b>No measurements in this project yet</b> ({esc(path.name)} is missing). "
            "Run the <b>Measurement</b> step (5): it drives the robot through the poses, locates the "
            "marker in 3D and writes measurements.csv. Then come back here.")
    if virtual:
        text += (f"<br><span style='color:{SYNTHETIC}'>Virtual lab, for teaching: you can also use "
                 f"<b>ideal synthetic measurements</b> — the lab's true robot at {DEFAULT_POSES} random "
                 f"visible poses plus noise σ = {DEFAULT_SIGMA_MM:g} mm, with no images "
                 "(no camera calibration or marker detection involved).</span>")
    return text


def unusable_html(message: str) -> str:
    return (f"<b>The measurements cannot be used:</b> {esc(message)}<br>"
            "Fix or replace the file, or run the Measurement step (5) again.")


def measurements_html(path: Path, meas, synthetic: str | None) -> str:
    """The file, its poses, points and targets, and SYNTHETIC in front when it is."""
    text = (f"<b>{esc(path.name)}</b>: {meas.n_poses} poses, {meas.n_points} points "
            f"(target {esc(', '.join(meas.target_names))}) — {esc(path.parent)}")
    if synthetic:
        text = f"<span style='color:{SYNTHETIC}'><b>SYNTHETIC:</b> " + esc(synthetic) + ".</span><br>" + text
    return text
