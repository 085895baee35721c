"""The report's identification section, from calibrated.json (or this session's result), the
nominal robot and measurements.csv: errors per pose before and after, their histograms on the
fitted and the held-out poses, the convergence, the parameter table nominal → identified ± σ
with the identifiability notes, and (virtual lab) the errors against the true robot. Lengths
in mm, angles in degrees."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from core.errors import RoboCalError
from core.report.compliance import deflection_blocks
from core.report.inputs import ReportInputs
from core.report.document import (Figure, Section, esc, not_done, num, panel, parameter_name, series, sig,
                                  table, unreadable)
from core.robot.model import RobotModel

TITLE = "Identification"
_ERRORS = (RoboCalError, KeyError, TypeError, ValueError, IndexError)


def _stats_table(rows: list[tuple[str, dict]]) -> str:
    return table(["", "mean", "RMS", "max", "points"],
                 [[esc(label), num(s.get("mean_mm")), f"<b>{num(s.get('rms_mm'))}</b>", num(s.get("max_mm")),
                   esc(s.get("n", ""))] for label, s in rows], numeric={1, 2, 3, 4})


def identification_section(inputs: ReportInputs, problems: list[str]) -> Section:
    """From this session's identification (wins over calibrated.json), the nominal robot,
    measurements.csv and (virtual lab) the accuracy against the true robot."""
    loaded = inputs.calibration
    if not loaded.present:
        return Section(TITLE, [not_done("no calibrated.json in the project")], done=False)
    if loaded.error is not None:
        if not isinstance(loaded.error, RoboCalError):
            raise loaded.error
        problems.append(f"calibrated.json: {loaded.error.message}")
        return Section(TITLE, [unreadable("calibrated.json", loaded.error.message)], done=False)
    calibration, model, source = loaded.value.section, loaded.value.model, loaded.value.source
    try:
        return Section(TITLE, _blocks(calibration, model, source, inputs.robot, inputs.accuracy,
                                      inputs.measurements.get()))
    except _ERRORS as exc:
        message = exc.message if isinstance(exc, RoboCalError) else f"unexpected content ({type(exc).__name__}: {exc})"
        problems.append(f"{source}: {message}")
        return Section(TITLE, [unreadable(source, message)], done=False)


def _blocks(calibration: dict, model: RobotModel, source: str, robot, accuracy, measurements) -> list:
    s = calibration.get("statistics", {}) or {}
    blocks: list = [f"<p class='note'>From {esc(source)}"
                    + (f", {esc(calibration.get('date'))}" if calibration.get("date") else "") + ".</p>"]
    blocks.append(f"<p>{esc(s.get('n_poses', '?'))} poses, {esc(s.get('n_points', '?'))} points; "
                  f"{esc(s.get('iterations', '?'))} iterations, "
                  f"{'converged' if s.get('converged') else 'not converged'}; "
                  f"{esc(s.get('n_parameters', '?'))} parameters estimated, rank {esc(s.get('rank', '?'))}, "
                  f"condition number κ = {sig(s.get('condition_number'), 4)}; "
                  f"estimated σ = {num(s.get('sigma_hat'), 4)} "
                  f"{'× the measurements’ own σ' if s.get('sigma_hat_unit') == '1' else 'mm per axis'}.</p>")
    v = s.get("validation")
    errors = _pose_errors(model, robot, v, measurements)
    before = {"rms_mm": s.get("rms_before_mm")}
    why_before = ""
    if isinstance(errors, PoseErrors):
        before = errors.fitted_before()
    else:
        why_before = (f"<p class='note'>Before calibration only the RMS is recorded in {esc(source)}; the mean and "
                      f"max {esc(errors)}.</p>")
    blocks.append("<h3>Position errors on the fitted poses (mm)</h3>"
                  + _stats_table([("before (nominal model, base registered)", before),
                                  ("after (calibrated model)", {"mean_mm": s.get("mean_after_mm"),
                                                                "rms_mm": s.get("rms_after_mm"),
                                                                "max_mm": s.get("max_after_mm"),
                                                                "n": s.get("n_points", "")})]) + why_before)
    if isinstance(v, dict):
        how = (f"{v.get('n_test_poses')} held-out poses ({float(v.get('fraction', 0)):.0%})"
               if v.get("method") == "holdout" else f"{v.get('folds')}-fold cross validation")
        blocks.append(f"<h3>Validation on poses left out of the fit (mm): {esc(how)}</h3>"
                      + _stats_table([("before", v.get("before", {})), ("after", v.get("after", {}))]))
    blocks += _error_figures(errors)
    blocks.append(_convergence(s))
    if accuracy is not None:
        a = accuracy.summary()
        blocks.append(f"<h3>Real accuracy against the virtual lab's true robot (mm): "
                      f"{esc(a.get('n_configurations'))} fresh random visible poses</h3>"
                      + _stats_table([("nominal model", a.get("nominal", {})),
                                      ("calibrated model", a.get("calibrated", {}))]))
        blocks.append(Figure(
            "identification_truth", "Errors against the true robot",
            "Distance between the true robot's marker and each model's prediction at fresh random poses the "
            "calibration never saw (the virtual lab knows the truth), before and after calibration.",
            [panel("histogram", "nominal model", "error (mm)", "points",
                   [series("nominal", values=accuracy.nominal.errors, color=1)]),
             panel("histogram", "calibrated model", "error (mm)", "points",
                   [series("calibrated", values=accuracy.calibrated.errors, color=0)])]))
    blocks += deflection_blocks(calibration, model, measurements)
    names, matrix = _correlation_matrix(calibration)
    together = not_separable(names, matrix)
    blocks.append(_parameters(calibration, together))
    blocks.append(_correlation(names, matrix))
    return blocks


STRONG_CORRELATION = 0.9        # |r| above this: the two parameters are hard to tell apart
STATUS_SHORT = {"identified": "✓", "not identifiable": "kept"}      # the parameter table's status column
NOT_SEPARABLE = 0.99            # |r| above this: the data determine only a combination of the two


def _correlation_matrix(calibration: dict) -> tuple[list[str], np.ndarray | None]:
    """The estimated parameters' names and their correlation matrix (None when calibrated.json
    does not record it)."""
    c = calibration.get("correlation")
    if not isinstance(c, dict):
        return [], None
    names = [str(n) for n in c["parameters"]]
    m = np.array([[np.nan if v is None else float(v) for v in row] for row in c["matrix"]], dtype=float)
    if m.shape != (len(names), len(names)):
        raise ValueError(f"correlation matrix of shape {m.shape} for {len(names)} parameters")
    return names, m


def not_separable_pairs(calibration: dict) -> list[tuple[str, str, float]]:
    """not_separable of the calibration's recorded correlation ([] when it records none or it
    cannot be read)."""
    try:
        return not_separable(*_correlation_matrix(calibration))
    except _ERRORS:
        return []


def not_separable(names: list[str], matrix: np.ndarray | None) -> list[tuple[str, str, float]]:
    """The pairs (a, b, r) of estimated parameters whose estimates correlate beyond ±NOT_SEPARABLE,
    strongest first: the measurements fix only a combination of the two."""
    if matrix is None:
        return []
    pairs = [(names[i], names[j], float(matrix[i, j])) for i in range(len(names)) for j in range(i)
             if np.isfinite(matrix[i, j]) and abs(matrix[i, j]) > NOT_SEPARABLE]
    return sorted(pairs, key=lambda t: -abs(t[2]))


def _separability_text(together: list[tuple[str, str, float]]) -> str:
    """One sentence per pair of parameters the data cannot separate."""
    if not together:
        return ""
    items = "".join(
        f"<li>{esc(parameter_name(a))} and {esc(parameter_name(b))} are not separable (r = {r:+.3f}): the "
        "measurements fix only a combination of the two, so neither value nor its σ means much alone; poses "
        "that move the joints they belong to more widely may separate them.</li>" for a, b, r in together)
    return (f"<h3>Parameters not separable (|r| &gt; {NOT_SEPARABLE})</h3><ul>{items}</ul>")


def _correlation(names: list[str], m: np.ndarray | None) -> Figure | str:
    """The correlation matrix of the estimated parameters (calibrated.json's 'correlation'), its
    rows and columns named by the parameters; a sentence when the file does not record it."""
    title = "Parameter correlation matrix"
    if m is None:
        return ("<p class='grey'>The parameters' correlation matrix is not shown: calibrated.json was written by "
                "an older version that did not record it (the Identification step shows it).</p>")
    strong = [(abs(m[i, j]), names[i], names[j], m[i, j]) for i in range(len(m)) for j in range(i)
              if np.isfinite(m[i, j]) and abs(m[i, j]) > STRONG_CORRELATION]
    strong.sort(reverse=True)
    caption = (f"Correlation between the estimates of the {len(names)} estimated parameters (blue −1, white 0, "
               "red +1). ")
    caption += ("Pairs above ±" + f"{STRONG_CORRELATION}: "
                + "; ".join(f"{parameter_name(a)}–{parameter_name(b)} {r:+.3f}" for _, a, b, r in strong[:8])
                + (f" and {len(strong) - 8} more" if len(strong) > 8 else "")
                + ": the data hardly tell these apart." if strong
                else f"No pair is above ±{STRONG_CORRELATION}: every estimate is well separated from the others.")
    side = max(420, min(900, 160 + 20 * len(names)))     # 20 px a row: an 8.5 pt name printed
    return Figure("identification_correlation", title, caption,
                  [{**panel("matrix", "", "", "", []), "matrix": m, "labels": [parameter_name(n) for n in names]}],
                  size=(side + 110, side + 30))


@dataclass
class PoseErrors:
    """Errors per point of the nominal model (base registered on the fitted poses) and of the
    calibrated model on every measured point (mm), and which poses were fitted or held out."""

    before: object                     # core.identification.result.ErrorStats
    after: object
    fit_ids: list[int]
    test_ids: list[int]

    def errors(self, stats, poses) -> np.ndarray:
        return stats.errors[np.isin(stats.pose, list(poses))]

    def fitted_before(self) -> dict:
        e = self.errors(self.before, self.fit_ids)
        return {"mean_mm": float(e.mean()), "rms_mm": float(np.sqrt(np.mean(e ** 2))), "max_mm": float(e.max()),
                "n": len(e)} if len(e) else {}


def _pose_errors(model: RobotModel, robot: RobotModel | None, validation, meas) -> PoseErrors | str:
    """The errors before and after on every measured point, or why they cannot be computed."""
    if meas is None:
        return "need the project's measurements.csv"
    if robot is None:
        return "need the project's nominal robot model (robot.json)"
    from core.identification.fit import error_stats, register_base
    from core.identification.validation import split_poses

    ids = [int(p) for p in meas.pose_ids]
    test: list[int] = []
    if isinstance(validation, dict) and validation.get("method") == "holdout":
        test = [int(p) for p in validation.get("test_poses") or []] or \
            split_poses(ids, float(validation["fraction"]), int(validation.get("seed", 0)))[1]
    held = set(test)
    train = [p for p in ids if p not in held]
    try:
        initial = register_base(robot, meas.select_poses(train))
        before, after = error_stats(initial, meas), error_stats(model, meas)
    except _ERRORS as exc:
        return f"cannot be computed: the models cannot predict these measurements ({getattr(exc, 'message', exc)})"
    return PoseErrors(before, after, train, [p for p in ids if p in held])


def _error_figures(errors: PoseErrors | str) -> list:
    titles = ("Error per pose, before and after", "Error histograms")
    if not isinstance(errors, PoseErrors):
        why = f"the errors per pose {errors}"
        return [f"<p class='grey'>No figure of the errors per pose and their histograms: {esc(why)}.</p>"]
    before, after, fit_ids, test_ids = errors.before, errors.after, errors.fit_ids, errors.test_ids
    b = {p["pose"]: p["error_mm"] for p in before.per_pose()}
    a = {p["pose"]: p["error_mm"] for p in after.per_pose()}
    per_pose = [series("before, fitted pose", fit_ids, [b[p] for p in fit_ids], color=1),
                series("after, fitted pose", fit_ids, [a[p] for p in fit_ids], color=0)]
    if test_ids:
        per_pose += [series("before, held-out pose", test_ids, [b[p] for p in test_ids], color=1, symbol="t"),
                     series("after, held-out pose", test_ids, [a[p] for p in test_ids], color=0, symbol="t")]
    held_text = (f" Triangles: the {len(test_ids)} poses held out of the fit (the calibrated model never saw "
                 "them)." if test_ids else "")
    fig1 = Figure("identification_per_pose", titles[0],
                  "RMS distance per pose between measured and predicted marker positions, nominal model (base "
                  "registered on the fitted poses) and calibrated model; log scale." + held_text,
                  [panel("points", "", "pose", "position error (mm)", per_pose, log_y=True)], size=(900, 290))

    panels = []
    for label, stats, color in (("before (nominal model)", before, 1), ("after (calibrated model)", after, 0)):
        data = [series("fitted poses", values=errors.errors(stats, fit_ids), color=color)]
        if test_ids:
            data.append(series("held-out poses", values=errors.errors(stats, test_ids), color=2))
        panels.append(panel("histogram", label, "position error (mm)", "points", data))
    fig2 = Figure("identification_histograms", titles[1],
                  "How the position errors are spread, before and after calibration (note the different "
                  "scales), on the fitted" + (" and on the held-out" if test_ids else "") + " poses.", panels,
                  size=(900, 340))
    return [fig1, fig2]


def _convergence(stats: dict) -> Figure:
    costs = [c for c in stats.get("cost_per_iteration") or [] if c is not None]
    title = "Convergence"
    if not costs:
        return Figure("identification_convergence", title, "",
                      unavailable="calibrated.json does not record the cost per iteration (written by an older "
                                  "version)")
    return Figure("identification_convergence", title,
                  "Least-squares cost (sum of squared, weighted residuals) after each iteration of the fit; "
                  "iteration 0 is the start (nominal model).",
                  [panel("points", "", "iteration", "cost (dimensionless)",
                         [series("cost", np.arange(len(costs)), costs, color=0, line=True)], log_y=True,
                         x_ticks=list(range(len(costs))) if len(costs) <= 30 else None)],
                  size=(900, 300))


def _parameters(calibration: dict, together: list[tuple[str, str, float]]) -> str:
    """The parameter table, the pairs the data cannot separate, the
    parameters not identifiable, fixed by the user, and the fit's warnings. A parameter in a pair
    that is not separable is listed "with" its partner, never as identified on its own."""
    params = calibration.get("parameters") or []
    partner: dict[str, list[str]] = {}
    for a, b, _r in together:
        partner.setdefault(a, []).append(parameter_name(b))
        partner.setdefault(b, []).append(parameter_name(a))
    parts = []
    if params:
        rows = []
        for p in params:
            deg = p.get("unit") == "deg"
            digits = 4 if deg else 3
            status = str(p.get("status", ""))
            status = STATUS_SHORT.get(status, status)
            if p.get("name") in partner:
                status = "only with " + ", ".join(partner[p.get("name")])
            unit = "°" if deg else p.get("unit", "")
            text = [esc(parameter_name(p.get("name"))), num(p.get("nominal"), digits), num(p.get("identified"), digits),
                    f"{sig(p.get('std'), 2)} {esc(unit)}" if p.get("std") is not None else esc(unit), esc(status)]
            if not p.get("identifiable"):
                text = [f"<span class='grey'>{t}</span>" for t in text]
            rows.append(text)
        header = ["parameter", "nominal", "identified", "± σ", "status"]
        parts.append("<h3>Parameters: nominal → identified ± σ</h3><p class='note'>✓ identified; grey: not "
                     "estimated, kept at its nominal value (“kept”: not identifiable, see below); “only with”: "
                     "not separable from that parameter (below).</p>"
                     + table(header, rows, numeric={1, 2, 3}))
    parts.append(_separability_text(together))
    unid = calibration.get("unidentifiable") or []
    if unid:
        parts.append("<h3>Not identifiable</h3><ul>"
                     + "".join(f"<li>{esc(u.get('name'))}: {esc(u.get('reason'))}</li>" for u in unid) + "</ul>")
    fixed = calibration.get("fixed") or []
    if fixed:
        parts.append(f"<p>Fixed by the user: {esc(', '.join(fixed))}.</p>")
    warnings = calibration.get("warnings") or []
    if warnings:
        parts.append("<h3>Warnings</h3><ul>" + "".join(f"<li class='warn'>{esc(w)}</li>" for w in warnings)
                     + "</ul>")
    return "".join(parts)
