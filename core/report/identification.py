"""The report's identification section, from calibrated.json (or this session's result), the
nominal robot and measurements.csv: errors per pose before and after, their histograms on the
fitted and the held-out poses, the convergence, the parameter table nominal → identified ± σ
with the identifiability notes, and (virtual lab) the errors against the true robot. Lengths
in mm, angles in degrees."""
from __future__ import annotations

import numpy as np

from core.errors import RoboCalError
from core.report.compliance import deflection_blocks
from core.project import Project
from core.report.document import (Figure, Section, esc, not_done, num, panel, series, sig, table,
                                  unreadable)
from core.robot.model import RobotModel

TITLE = "Identification"
_ERRORS = (RoboCalError, KeyError, TypeError, ValueError, IndexError)


def _stats_table(rows: list[tuple[str, dict]]) -> str:
    return table(["", "mean", "RMS", "max", "points"],
                 [[esc(label), num(s.get("mean_mm")), f"<b>{num(s.get('rms_mm'))}</b>", num(s.get("max_mm")),
                   esc(s.get("n", ""))] for label, s in rows], numeric={1, 2, 3, 4})


def identification_section(project: Project, robot: RobotModel | None, identification, accuracy,
                           facts: dict, problems: list[str]) -> Section:
    """`identification`: an IdentificationResult of this session (wins over calibrated.json);
    `accuracy`: a model_comparison.TruthAccuracy or None. Puts 'validation', 'statistics' and
    'accuracy' into `facts`."""
    if identification is not None:
        calibration, model, source = identification.calibration_section(), identification.model, \
            "this session's identification"
    elif project.has("calibrated"):
        path = project.path("calibrated")
        try:
            from core.robot.file import read_robot
            model = read_robot(path)
            calibration = model.calibration
            if not isinstance(calibration, dict):
                raise RoboCalError("no calibration section: this is a robot model, not a calibrated one",
                                   source=path, field="calibration")
        except RoboCalError as exc:
            problems.append(f"calibrated.json: {exc.message}")
            return Section(TITLE, [unreadable("calibrated.json", exc.message)], done=False)
        source = path.name
    else:
        return Section(TITLE, [not_done("no calibrated.json in the project")], done=False)
    try:
        return Section(TITLE, _blocks(calibration, model, source, robot, accuracy, facts))
    except _ERRORS as exc:
        message = exc.message if isinstance(exc, RoboCalError) else f"unexpected content ({type(exc).__name__}: {exc})"
        problems.append(f"{source}: {message}")
        return Section(TITLE, [unreadable(source, message)], done=False)


def _blocks(calibration: dict, model: RobotModel, source: str, robot, accuracy, facts: dict) -> list:
    s = calibration.get("statistics", {}) or {}
    facts["statistics"] = s
    blocks: list = [f"<p class='note'>From {esc(source)}"
                    + (f", {esc(calibration.get('date'))}" if calibration.get("date") else "") + ".</p>"]
    blocks.append(f"<p>{esc(s.get('n_poses', '?'))} poses, {esc(s.get('n_points', '?'))} points; "
                  f"{esc(s.get('iterations', '?'))} iterations, "
                  f"{'converged' if s.get('converged') else 'not converged'}; "
                  f"{esc(s.get('n_parameters', '?'))} parameters estimated, rank {esc(s.get('rank', '?'))}, "
                  f"condition number κ = {sig(s.get('condition_number'), 4)}; "
                  f"estimated σ = {num(s.get('sigma_hat'), 4)} "
                  f"{'× the measurements’ own σ' if s.get('sigma_hat_unit') == '1' else 'mm per axis'}.</p>")
    blocks.append("<h3>Position errors on the fitted poses (mm)</h3>"
                  + _stats_table([("before (nominal model, base registered)", {"rms_mm": s.get("rms_before_mm")}),
                                  ("after (calibrated model)", {"mean_mm": s.get("mean_after_mm"),
                                                                "rms_mm": s.get("rms_after_mm"),
                                                                "max_mm": s.get("max_after_mm"),
                                                                "n": s.get("n_points", "")})]))
    v = s.get("validation")
    if isinstance(v, dict):
        facts["validation"] = v
        how = (f"{v.get('n_test_poses')} held-out poses ({float(v.get('fraction', 0)):.0%})"
               if v.get("method") == "holdout" else f"{v.get('folds')}-fold cross validation")
        blocks.append(f"<h3>Validation on poses left out of the fit (mm): {esc(how)}</h3>"
                      + _stats_table([("before", v.get("before", {})), ("after", v.get("after", {}))]))
    blocks += _error_figures(model, robot, v, facts.get("measurements"))
    blocks.append(_convergence(s))
    if accuracy is not None:
        facts["accuracy"] = accuracy
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
    blocks += deflection_blocks(calibration, model, facts.get("measurements"))
    blocks.append(_parameters(calibration))
    blocks.append(_correlation(calibration))
    return blocks


STRONG_CORRELATION = 0.9        # |r| above this: the two parameters are hard to tell apart


def _correlation(calibration: dict) -> Figure:
    """The correlation matrix of the estimated parameters (calibrated.json's 'correlation')."""
    title = "Parameter correlation matrix"
    c = calibration.get("correlation")
    if not isinstance(c, dict):
        return Figure("identification_correlation", title, "",
                      unavailable="calibrated.json does not record the parameters' correlation (written by an "
                                  "older version); the Identification step shows it")
    names = [str(n) for n in c["parameters"]]
    m = np.array([[np.nan if v is None else float(v) for v in row] for row in c["matrix"]], dtype=float)
    if m.shape != (len(names), len(names)):
        raise ValueError(f"correlation matrix of shape {m.shape} for {len(names)} parameters")
    strong = [(abs(m[i, j]), names[i], names[j], m[i, j]) for i in range(len(m)) for j in range(i)
              if np.isfinite(m[i, j]) and abs(m[i, j]) > STRONG_CORRELATION]
    strong.sort(reverse=True)
    key = ", ".join(f"{i + 1} {n}" for i, n in enumerate(names))
    caption = (f"Correlation between the estimates of the {len(names)} estimated parameters (blue −1, white 0, "
               f"red +1); row and column i are parameter i: {key}. ")
    caption += ("Pairs above ±" + f"{STRONG_CORRELATION}: " + "; ".join(f"{a}–{b} {r:+.3f}" for _, a, b, r in strong[:8])
                + (f" and {len(strong) - 8} more" if len(strong) > 8 else "")
                + ": the data hardly tell these apart." if strong
                else f"No pair is above ±{STRONG_CORRELATION}: every estimate is well separated from the others.")
    return Figure("identification_correlation", title, caption,
                  [{**panel("matrix", "", "parameter (number)", "parameter (number)", []), "matrix": m}],
                  size=(620, 540))


def _error_figures(model: RobotModel, robot: RobotModel | None, validation, meas) -> list:
    titles = ("Error per pose, before and after", "Error histograms")
    why = None
    if meas is None:
        why = "needs the project's measurements.csv"
    elif robot is None:
        why = "needs the project's nominal robot model (robot.json)"
    if why:
        return [Figure("identification_per_pose", titles[0], "", unavailable=why),
                Figure("identification_histograms", titles[1], "", unavailable=why)]
    from core.identification.fit import error_stats, register_base
    from core.identification.validation import split_poses

    ids = [int(p) for p in meas.pose_ids]
    test: list[int] = []
    if isinstance(validation, dict) and validation.get("method") == "holdout":
        test = [int(p) for p in validation.get("test_poses") or []] or \
            split_poses(ids, float(validation["fraction"]), int(validation.get("seed", 0)))[1]
    train = [p for p in ids if p not in set(test)]
    try:
        initial = register_base(robot, meas.select_poses(train))
        before, after = error_stats(initial, meas), error_stats(model, meas)
    except _ERRORS as exc:
        why = f"the models cannot predict these measurements: {getattr(exc, 'message', exc)}"
        return [Figure("identification_per_pose", titles[0], "", unavailable=why),
                Figure("identification_histograms", titles[1], "", unavailable=why)]
    b = {p["pose"]: p["error_mm"] for p in before.per_pose()}
    a = {p["pose"]: p["error_mm"] for p in after.per_pose()}
    held = set(test)
    fit_ids, test_ids = [p for p in ids if p not in held], [p for p in ids if p in held]
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
                  [panel("points", "", "pose", "position error (mm)", per_pose, log_y=True)])

    def errs(stats, wanted):
        keep = np.isin(stats.pose, list(wanted))
        return stats.errors[keep]

    panels = []
    for label, stats, color in (("before (nominal model)", before, 1), ("after (calibrated model)", after, 0)):
        data = [series("fitted poses", values=errs(stats, fit_ids), color=color)]
        if test_ids:
            data.append(series("held-out poses", values=errs(stats, test_ids), color=2))
        panels.append(panel("histogram", label, "position error (mm)", "points", data))
    fig2 = Figure("identification_histograms", titles[1],
                  "How the position errors are spread, before and after calibration (note the different "
                  "scales), on the fitted" + (" and on the held-out" if test_ids else "") + " poses.", panels)
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


def _parameters(calibration: dict) -> str:
    params = calibration.get("parameters") or []
    parts = []
    if params:
        rows = []
        for p in params:
            deg = p.get("unit") == "deg"
            digits = 4 if deg else 3
            text = [esc(p.get("name")), num(p.get("nominal"), digits), num(p.get("identified"), digits),
                    sig(p.get("std"), 2) if p.get("std") is not None else "—", esc("°" if deg else p.get("unit", "")),
                    esc(p.get("status", ""))]
            if not p.get("identifiable"):
                text = [f"<span class='grey'>{t}</span>" for t in text]
            rows.append(text)
        parts.append("<h3>Parameters: nominal → identified ± σ</h3><p class='note'>Grey: not estimated, kept at "
                     "nominal.</p>"
                     + table(["parameter", "nominal", "identified", "± σ", "unit", "status"], rows,
                             numeric={1, 2, 3}))
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
