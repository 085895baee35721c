"""A short HTML report of a calibration: the figures of every step that has produced something.

    html = calibration_report(project, robot=..., identification=result, accuracy=accuracy)

It reads what the project folder holds (stereo.yaml, poses.csv, measurements.csv,
calibrated.json) and takes the in-memory results of the session when given (they win over
the files: they are what the user has just seen). A step with no output is listed as "not
done"; a file that cannot be read is reported with its error instead of failing the report.
All lengths in mm, angles in degrees, image errors in px.
"""
from __future__ import annotations

import html
import math
from datetime import datetime, timezone
from pathlib import Path

from core.errors import RoboCalError
from core.files import read_json
from core.measurement.synthetic import synthetic_description
from core.robot.model import RobotModel
from core.project import OUTPUT_FILES, VIRTUAL_LAB, Project

STYLE = """
body { font-family: sans-serif; font-size: 10.5pt; color: #202124; max-width: 60em; margin: 1.5em auto; }
h1 { font-size: 17pt; margin-bottom: 0.2em; }
h2 { font-size: 12.5pt; color: #1a73e8; margin-top: 1.4em; border-bottom: 1px solid #dadce0; }
table { border-collapse: collapse; margin: 0.4em 0; }
td, th { padding: 2px 10px 2px 0; text-align: left; vertical-align: top; }
td.n, th.n { text-align: right; }
.grey { color: #80868b; }
.warn { color: #b06000; }
.note { color: #5f6368; font-size: 9.5pt; }
"""


def _e(text) -> str:
    return html.escape(str(text))


def _f(value, digits: int = 3) -> str:
    if value is None:
        return "—"
    try:
        v = float(value)
    except (TypeError, ValueError):
        return _e(value)
    return "—" if not math.isfinite(v) else f"{v:.{digits}f}"


def _g(value, digits: int = 4) -> str:
    if value is None:
        return "—"
    v = float(value)
    return "∞" if math.isinf(v) else ("—" if math.isnan(v) else f"{v:.{digits}g}")


def _stats_table(rows: list[tuple[str, dict]]) -> str:
    out = ['<table><tr><th></th><th class="n">mean</th><th class="n">RMS</th><th class="n">max</th>'
           '<th class="n">points</th></tr>']
    for label, s in rows:
        out.append(f'<tr><td>{_e(label)}</td><td class="n">{_f(s.get("mean_mm"))}</td>'
                   f'<td class="n"><b>{_f(s.get("rms_mm"))}</b></td><td class="n">{_f(s.get("max_mm"))}</td>'
                   f'<td class="n">{_e(s.get("n", ""))}</td></tr>')
    out.append("</table>")
    return "".join(out)


def _count_rows(path: Path) -> int:
    """Data rows of a CSV file with one header line and # comments."""
    lines = [ln for ln in path.read_text(encoding="utf-8-sig").splitlines() if ln.strip() and not ln.startswith("#")]
    return max(0, len(lines) - 1)


# -- sections ------------------------------------------------------------------------------
def _stereo_section(project: Project) -> str:
    path = project.path("stereo")
    if not path.is_file():
        return "<h2>Stereo calibration</h2><p class='grey'>Not done (no stereo.yaml in the project).</p>"
    try:
        from core.stereo.file import read_stereo_yaml
        sf = read_stereo_yaml(path)
    except RoboCalError as exc:
        return f"<h2>Stereo calibration</h2><p class='warn'>stereo.yaml cannot be read: {_e(exc.message)}</p>"
    w, h = sf.image_size
    rows = [("image size", f"{w} × {h} px"),
            ("reprojection error, left camera", _rms(sf.rms_left)),
            ("reprojection error, right camera", _rms(sf.rms_right)),
            ("reprojection error, stereo", _rms(sf.rms_stereo)),
            ("baseline", f"{_f(sf.baseline_mm, 2)} mm"),
            ("focal lengths (left)", f"{_f(sf.K1[0, 0], 1)}, {_f(sf.K1[1, 1], 1)} px"),
            ("checkerboard", f"{sf.board.cols} × {sf.board.rows} inner corners, {_f(sf.board.square, 2)} mm"
             if sf.board is not None else "unknown (not in the imported calibration)")]
    if "epipolar_rms" in sf.extras:
        rows.append(("epipolar error after rectification", f"{_f(sf.extras['epipolar_rms'])} px RMS"))
    if "cross_validation_px" in sf.extras:
        rows.append(("cross validation", f"{_f(sf.extras['cross_validation_px'])} px RMS"))
    return ("<h2>Stereo calibration</h2><table>"
            + "".join(f"<tr><td>{_e(k)}</td><td>{v}</td></tr>" for k, v in rows) + "</table>")


def _rms(value) -> str:
    """An RMS error (px), or unknown for a calibration imported without its statistics."""
    return "unknown (not in the imported calibration)" if value is None else f"{_f(value)} px RMS"


def _poses_section(project: Project) -> str:
    path = project.path("poses")
    if not path.is_file():
        return "<h2>Pose sequence</h2><p class='grey'>Not done (no poses.csv in the project).</p>"
    try:
        from core.poses.file import read_poses
        n = len(read_poses(path))
    except ImportError:            # a build without the pose file module: count the data rows
        try:
            n = _count_rows(path)
        except (OSError, UnicodeDecodeError) as exc:
            return f"<h2>Pose sequence</h2><p class='warn'>poses.csv cannot be read: {_e(exc)}</p>"
    except RoboCalError as exc:
        return f"<h2>Pose sequence</h2><p class='warn'>poses.csv cannot be read: {_e(exc.message)}</p>"
    return f"<h2>Pose sequence</h2><p>{n} poses in poses.csv.</p>"


def _measurement_section(project: Project, robot: RobotModel | None) -> str:
    path = project.path("measurements")
    if not path.is_file():
        return "<h2>Measurements</h2><p class='grey'>Not done (no measurements.csv in the project).</p>"
    from core.measurement.file import read_measurements
    try:
        meas = read_measurements(path, robot)
    except RoboCalError as exc:
        return f"<h2>Measurements</h2><p class='warn'>measurements.csv cannot be read: {_e(exc.message)}</p>"
    text = (f"<h2>Measurements</h2><p>{meas.n_poses} poses, {meas.n_points} measured points "
            f"(targets: {_e(', '.join(meas.target_names))}).</p>")
    synthetic = synthetic_description(path)
    if synthetic:
        text += f"<p class='warn'><b>Synthetic:</b> {_e(synthetic)}.</p>"
    return text


def _identification_section(calibration: dict | None, source: str, accuracy: dict | None) -> str:
    if calibration is None:
        return "<h2>Identification</h2><p class='grey'>Not done (no calibrated.json in the project).</p>"
    s = calibration.get("statistics", {}) or {}
    parts = [f"<h2>Identification</h2><p class='note'>From {_e(source)}"
             + (f", {_e(calibration.get('date'))}" if calibration.get("date") else "") + ".</p>"]
    parts.append(f"<p>{_e(s.get('n_poses', '?'))} poses, {_e(s.get('n_points', '?'))} points; "
                 f"{_e(s.get('iterations', '?'))} iterations, "
                 f"{'converged' if s.get('converged') else 'not converged'}; "
                 f"{_e(s.get('n_parameters', '?'))} parameters estimated, rank {_e(s.get('rank', '?'))}, "
                 f"condition number κ = {_g(s.get('condition_number'))}; "
                 f"σ̂ = {_f(s.get('sigma_hat'), 4)} "
                 f"{'× the measurements’ own σ' if s.get('sigma_hat_unit') == '1' else 'mm per axis'}.</p>")
    parts.append("<p><b>Position errors on the fitted poses (mm)</b></p>")
    parts.append(_stats_table([("before (nominal model, base registered)", {"rms_mm": s.get("rms_before_mm")}),
                               ("after (calibrated model)", {"mean_mm": s.get("mean_after_mm"),
                                                             "rms_mm": s.get("rms_after_mm"),
                                                             "max_mm": s.get("max_after_mm"),
                                                             "n": s.get("n_points", "")})]))
    v = s.get("validation")
    if isinstance(v, dict):
        how = (f"{v.get('n_test_poses')} held-out poses ({float(v.get('fraction', 0)):.0%})"
               if v.get("method") == "holdout" else f"{v.get('folds')}-fold cross validation")
        parts.append(f"<p><b>Validation on poses left out of the fit (mm)</b>: {_e(how)}</p>")
        parts.append(_stats_table([("before", v.get("before", {})), ("after", v.get("after", {}))]))
    if accuracy:
        parts.append(f"<p><b>Real accuracy against the virtual lab's true robot (mm)</b>: "
                     f"{_e(accuracy.get('n_configurations'))} fresh random visible poses</p>")
        parts.append(_stats_table([("nominal model", accuracy.get("nominal", {})),
                                   ("calibrated model", accuracy.get("calibrated", {}))]))
    params = calibration.get("parameters") or []
    if params:
        rows = ["<table><tr><th>parameter</th><th class='n'>nominal</th><th class='n'>identified</th>"
                "<th class='n'>± σ</th><th>unit</th><th>status</th></tr>"]
        for p in params:
            grey = "" if p.get("identifiable") else " class='grey'"
            unit = "°" if p.get("unit") == "deg" else p.get("unit", "")
            digits = 4 if p.get("unit") == "deg" else 3
            rows.append(f"<tr{grey}><td>{_e(p.get('name'))}</td><td class='n'>{_f(p.get('nominal'), digits)}</td>"
                        f"<td class='n'>{_f(p.get('identified'), digits)}</td>"
                        f"<td class='n'>{_g(p.get('std'), 2) if p.get('std') is not None else '—'}</td>"
                        f"<td>{_e(unit)}</td><td>{_e(p.get('status', ''))}</td></tr>")
        rows.append("</table>")
        parts.append("<p><b>Parameters</b> (grey: not estimated, kept at nominal)</p>" + "".join(rows))
    unid = calibration.get("unidentifiable") or []
    if unid:
        parts.append("<p><b>Not identifiable</b></p><ul>"
                     + "".join(f"<li>{_e(u.get('name'))}: {_e(u.get('reason'))}</li>" for u in unid) + "</ul>")
    fixed = calibration.get("fixed") or []
    if fixed:
        parts.append(f"<p>Fixed by the user: {_e(', '.join(fixed))}.</p>")
    warnings = calibration.get("warnings") or []
    if warnings:
        parts.append("<p><b>Warnings</b></p><ul>" + "".join(f"<li class='warn'>{_e(w)}</li>" for w in warnings)
                     + "</ul>")
    return "".join(parts)


# -- the report ------------------------------------------------------------------------------
def calibration_report(project: Project, *, robot: RobotModel | None = None, identification=None,
                       accuracy=None, date: str | None = None) -> str:
    """The report as an HTML document. `identification`: an IdentificationResult of this
    session (else calibrated.json is read); `accuracy`: a model_comparison.TruthAccuracy."""
    date = date or datetime.now(timezone.utc).replace(microsecond=0).isoformat().replace("+00:00", " UTC")
    calibration, source = None, ""
    if identification is not None:
        calibration, source = identification.calibration_section(), "this session's identification"
    elif project.has("calibrated"):
        path = project.path("calibrated")
        try:
            calibration = read_json(path).get("calibration")
            source = path.name
        except RoboCalError as exc:
            calibration = None
            source = f"{path.name} (cannot be read: {exc.message})"
    mode = "virtual lab (simulated robot and cameras)" if project.mode == VIRTUAL_LAB else "hardware"
    robot_name = robot.name if robot is not None else "—"
    files = "".join(f"<tr><td>{_e(name)}</td><td>{'present' if project.has(key) else '<span class=grey>missing</span>'}"
                    f"</td></tr>" for key, name in OUTPUT_FILES.items())
    body = [f"<h1>RoboCal calibration report: {_e(project.name)}</h1>",
            f"<p class='note'>{_e(date)} · project folder {_e(project.folder)} · mode: {_e(mode)} · "
            f"robot: {_e(robot_name)}</p>",
            "<h2>Project files</h2><table>" + files + "</table>",
            _stereo_section(project), _poses_section(project), _measurement_section(project, robot),
            _identification_section(calibration, source, accuracy.summary() if accuracy is not None else None),
            "<p class='note'>Lengths in mm, angles in degrees, image errors in px. RMS = root mean square of "
            "the 3D distance between measured (or true) and predicted marker positions.</p>"]
    if calibration is None and source:
        body.insert(-1, f"<p class='warn'>calibrated.json: {_e(source)}</p>")
    return ("<!DOCTYPE html>\n<html><head><meta charset='utf-8'>"
            f"<title>RoboCal report: {_e(project.name)}</title><style>{STYLE}</style></head><body>\n"
            + "\n".join(body) + "\n</body></html>\n")
