"""The report's Check section (the calibrated cell watched over time), from the project's check
log (checks.csv), calibrated.json and fixture_pose.json: the control charts of every check
against its limits, the diagnosis of the last check when it left its limits, the
re-identifications with their history, the tools and their offsets, and the fixtures located.
Lengths in mm, angles in degrees."""
from __future__ import annotations

from datetime import datetime

import numpy as np

from core.errors import RoboCalError
from core.project import Output, Project
from core.report.inputs import ReportInputs
from core.report.document import Figure, Section, esc, not_done, num, panel, series, table, unreadable

TITLE = "Check"
LOG_FILE = "checks.csv"
FIXTURE_FILE = "fixture_pose.json"
MAX_CHECKS_LISTED = 20
MAX_TICKS = 12              # check numbers labelled one by one up to this many checks


def check_section(inputs: ReportInputs, problems: list[str]) -> Section:
    project = inputs.project
    log_path = project.folder / LOG_FILE
    model = _calibrated(project)
    history = list(((model.calibration or {}).get("history") or []) if model is not None else [])
    fixture = project.folder / FIXTURE_FILE
    if not log_path.is_file() and not history and not fixture.is_file():
        return Section(TITLE, [not_done("no check log (checks.csv), re-identification or fixture in the project")],
                       done=False)
    blocks: list = []
    log = None
    if log_path.is_file():
        from core.monitoring.log import read_check_log
        try:
            log = read_check_log(log_path)
        except RoboCalError as exc:
            problems.append(f"{LOG_FILE}: {exc.message}")
            blocks.append(unreadable(LOG_FILE, exc.message))
    if log is not None and log.checks:
        blocks += _checks(log)
        blocks.append(_diagnosis(log, model, history))
    elif log is not None or not log_path.is_file():
        blocks.append("<p class='grey'>No check in the log yet.</p>")
    blocks.append(_history(history))
    if model is not None:
        blocks.append(_tools(model, history))
    blocks.append(_fixture(fixture, problems))
    return Section(TITLE, blocks)


def _calibrated(project: Project):
    """The calibrated robot, None when there is none or it cannot be read (the Identification
    section names the problem)."""
    if not project.has(Output.CALIBRATED):
        return None
    from core.robot.file import read_robot
    try:
        return read_robot(project.path(Output.CALIBRATED))
    except RoboCalError:
        return None


def _checks(log) -> list:
    checks = log.checks
    finished = [c for c in checks if c.finished]
    out = sum(1 for c in finished if not c.within)
    last = checks[-1]
    text = (f"<p>{len(checks)} checks in {esc(LOG_FILE)} ({len(finished)} finished, {out} out of limits); the last "
            f"on {esc(last.time.replace('T', ' ')[:19])} UTC"
            + (f", {'within limits' if last.within else '<b>out of limits</b>'}" if last.finished else ", not finished")
            + ".</p>")
    rows = []
    for k, c in list(enumerate(checks, 1))[-MAX_CHECKS_LISTED:]:
        beyond = sum(1 for p in c.points if not p.within)
        verdict = "—" if not c.finished else ("within" if c.within else "<b>OUT</b>")
        rows.append([str(k), esc(c.time.replace("T", " ")[:19]), esc(c.tool or "—"), str(len(c.points)),
                     str(beyond), num(c.rms_mm), num(c.rms_limit_mm), verdict])
    listed = table(["check", "time (UTC)", "tool", "points", "beyond", "RMS (mm)", "limit (mm)", "verdict"],
                   rows, numeric={0, 3, 4, 5, 6})
    if len(checks) > MAX_CHECKS_LISTED:
        listed += f"<p class='note'>The last {MAX_CHECKS_LISTED} of {len(checks)} checks.</p>"
    return [text, _control_chart(checks), listed]


def _control_chart(checks) -> Figure:
    done = [(k, c) for k, c in enumerate(checks, 1) if c.finished]
    x = [k for k, _ in done]
    overall = [series("RMS error", x, [c.rms_mm for _, c in done], color=0, line=True),
               series("limit", x, [c.rms_limit_mm for _, c in done], color=4, symbol="t", line=True)]
    beyond = [(k, c.rms_mm) for k, c in done if not c.within]
    if beyond:
        overall.append(series("beyond the limit", *zip(*beyond), color=1, symbol="x"))
    inside = [(k, p.error_mm / p.limit_mm) for k, c in enumerate(checks, 1) for p in c.points
              if p.within and p.limit_mm > 0]
    outside = [(k, p.error_mm / p.limit_mm) for k, c in enumerate(checks, 1) for p in c.points
               if not p.within and p.limit_mm > 0]
    ticks = list(range(1, len(checks) + 1)) if len(checks) <= MAX_TICKS else None
    points = []
    if inside:
        points.append(series("within its limit", *zip(*inside), color=0))
    if outside:
        points.append(series("beyond its limit", *zip(*outside), color=1, symbol="x"))
    figure = Figure(
        "check_control", "Control charts of the checks",
        "Left: each finished check's RMS error over its poses against its limit (from the calibration's own "
        "uncertainty and the false-alarm rate), mm. Right: every check point's error divided by its own limit: "
        "above 1 the marker is further from the calibrated model's prediction than the calibration explains.",
        [panel("points", "overall RMS per check", "check number", "error (mm)", overall, x_ticks=ticks),
         panel("points", "each point / its limit", "check number", "error / limit", points,
               hlines=[(1.0, "limit")], x_ticks=ticks)])
    if not done and not inside and not outside:
        figure.panels, figure.unavailable = [], "no check point in the log"
    return figure


def _parse_time(text: str) -> datetime | None:
    try:
        return datetime.fromisoformat(str(text))
    except (TypeError, ValueError):
        return None


def _diagnosis(log, model, history: list) -> str:
    """The diagnosis of the last finished check when it left its limits and no re-identification
    came after it (recomputed against calibrated.json, which it was checked against)."""
    finished = [c for c in log.checks if c.finished]
    if not finished:
        return "<h3>Diagnosis</h3><p class='grey'>No check finished yet.</p>"
    last = finished[-1]
    if last.within:
        return ("<h3>Diagnosis</h3><p>The last check is within its limits: the marker is where the calibrated "
                "model puts it.</p>")
    updated = [_parse_time(h.get("date")) for h in history if isinstance(h, dict)]
    when = _parse_time(last.time)
    if updated and when is not None and any(u is not None and u >= when for u in updated):
        return ("<h3>Diagnosis</h3><p>The last check out of limits was followed by a re-identification (below); "
                "its diagnosis is the reason recorded there.</p>")
    if model is None:
        return "<h3>Diagnosis</h3><p class='grey'>Not available: no readable calibrated.json.</p>"
    try:
        text = _diagnose(last, model)
    except (RoboCalError, ValueError, KeyError) as exc:
        message = exc.message if isinstance(exc, RoboCalError) else str(exc)
        return f"<h3>Diagnosis</h3><p class='warn'>The last check left its limits; not diagnosed: {esc(message)}</p>"
    return f"<h3>Diagnosis of the last check</h3><p><b>{esc(text)}</b></p>"


def _diagnose(check, model) -> str:
    from core.monitoring.check import DEFAULT_ALPHA, CheckPoint, CheckResult
    from core.monitoring.diagnosis import diagnose
    from core.monitoring.uncertainty import calibration_uncertainty

    unc = calibration_uncertainty(model)
    points = [CheckPoint(p.pose, p.target, p.q_file, model.q_from_file(p.q_file), p.measured, p.predicted,
                         p.limit_mm, p.covariance) for p in check.points]
    result = CheckResult(check.run, check.time, points, float(check.rms_mm), float(check.rms_limit_mm),
                         DEFAULT_ALPHA, unc.sigma_mm, tool=check.tool)
    return diagnose(model, unc, result).text


def _history(history: list) -> str:
    if not history:
        return ("<h3>Re-identifications</h3><p>None: calibrated.json is the calibration as identified "
                "(no change re-identified since).</p>")
    rows = []
    for h in history:
        if not isinstance(h, dict):
            continue
        rows.append([esc(str(h.get("date", "")).replace("T", " ")[:19]), esc(h.get("reason", "")),
                     esc(", ".join(h.get("changed", []) or [])), esc(h.get("poses", "")),
                     f"{num(h.get('rms_before_mm'))} → {num(h.get('rms_after_mm'))}", esc(h.get("updated", ""))])
    return ("<h3>Re-identifications</h3><p>What changed, from the check's points and a few proposed poses, with the "
            "calibration as prior; the file replaced is kept in history/.</p>"
            + table(["date (UTC)", "reason", "parameters", "poses", "RMS before → after (mm)", "previous file"],
                    rows, numeric={3}))


def _tools(model, history: list) -> str:
    from core.monitoring.tool_identification import calibrated_tools
    from core.monitoring.uncertainty import calibration_uncertainty

    try:
        calibrated = set(calibrated_tools(model, calibration_uncertainty(model)))
    except RoboCalError:
        calibrated = set()
    identified = {h["tool"]: str(h.get("date", "")).replace("T", " ")[:19] for h in history
                  if isinstance(h, dict) and h.get("tool")}
    rows = []
    for tool, targets in model.tool_map().items():
        for target in targets:
            p = np.asarray(model.targets[target], dtype=float)
            rows.append([esc(tool), esc(target), ", ".join(f"{v:.3f}" for v in p),
                         "yes" if tool in calibrated else "no", esc(identified.get(tool, "—"))])
    return ("<h3>Tools</h3><p>Each tool's marker points in the tool frame, as the calibrated robot file holds them; "
            "a calibrated tool can be checked; a tool mounted later is identified from its own few poses.</p>"
            + table(["tool", "target", "x, y, z (mm)", "calibrated", "identified on (UTC)"], rows))


def _fixture(path, problems: list[str]) -> str:
    if not path.is_file():
        return "<h3>Fixtures</h3><p class='grey'>No fixture located (no fixture_pose.json).</p>"
    from core.fixtures.file import read_fixture_pose
    try:
        pose = read_fixture_pose(path)
    except RoboCalError as exc:
        problems.append(f"{FIXTURE_FILE}: {exc.message}")
        return "<h3>Fixtures</h3>" + unreadable(FIXTURE_FILE, exc.message)
    f = pose.frame
    rows = [["position (mm)", ", ".join(f"{v:.3f} ± {s:.3f}" for v, s in zip(f.position, f.sigma_position_mm))],
            ["roll, pitch, yaw (°)", ", ".join(f"{v:.3f} ± {s:.3f}" for v, s in zip(f.rpy_deg, f.sigma_rotation_deg))],
            ["method", esc(f.method)], ["points", esc(", ".join(f.names))], ["RMS residual (mm)", num(f.rms_mm)]]
    return (f"<h3>Fixtures</h3><p>“{esc(pose.name)}” located in the robot's base frame ({esc(FIXTURE_FILE)}):</p>"
            + table([], rows))
