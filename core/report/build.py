"""The whole report of a project: header, summary box, one section per step.

    report = build_report(project)                 # what the project folder holds
    report = build_report(project, robot=..., identification=result, accuracy=accuracy)

The in-memory results of a session win over the files (they are what the user has just
seen). A step with no output is listed as not done; a file that cannot be read is named with
its error, never a crash. All lengths in mm, angles in degrees, image errors in px.
"""
from __future__ import annotations

import importlib.metadata
import math
import traceback
from datetime import datetime, timezone

from core.errors import RoboCalError
from core.project import OUTPUT_FILES, VIRTUAL_LAB, Project, load_robot
from core.report.check import check_section
from core.report.compensation import compensation_section
from core.report.document import Report, Section, esc, num, table, unreadable
from core.report.identification import identification_section
from core.report.marker import MARKER_FILE, marker_section
from core.report.measurement import measurement_section
from core.report.poses import poses_section
from core.report.stereo import stereo_section
from core.robot.model import RobotModel

FOOTER = ("<p class='note'>Lengths in mm, angles in degrees, image errors in px. RMS = root mean square of the 3D "
          "distance between measured (or true) and predicted marker positions. Held-out poses were left out of "
          "the fit: their error is what the calibrated robot achieves on poses it was not fitted to.</p>")


def software_version() -> str:
    try:
        return importlib.metadata.version("robocal")
    except importlib.metadata.PackageNotFoundError:
        return "unknown"


def build_report(project: Project, *, robot: RobotModel | None = None, identification=None, accuracy=None,
                 date: str | None = None, author: str | None = None, course: str | None = None) -> Report:
    """The report of `project`. `robot`: the nominal model (else the project's robot.json);
    `identification`: an IdentificationResult of this session (else calibrated.json);
    `accuracy`: a model_comparison.TruthAccuracy (virtual lab only); `author`, `course`: who
    hands the report in and for which course, on the title page."""
    date = date or datetime.now(timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    problems: list[str] = []
    facts: dict = {}
    if robot is None and project.robot:
        try:
            robot = load_robot(project)
        except RoboCalError as exc:
            problems.append(f"{project.robot}: {exc.message}")
    builders = [
        ("Stereo calibration", lambda: stereo_section(project, facts, problems)),
        ("Marker", lambda: marker_section(project, facts, problems)),
        ("Pose sequence", lambda: poses_section(project, robot, facts, problems)),
        ("Measurements", lambda: measurement_section(project, robot, facts, problems)),
        ("Identification", lambda: identification_section(project, robot, identification, accuracy, facts,
                                                          problems)),
        ("Check", lambda: check_section(project, facts, problems)),
        ("Compensation", lambda: compensation_section(project, robot, facts, problems)),
    ]
    sections = [_files_section(project, robot)]
    for title, build in builders:
        try:
            sections.append(build())
        except Exception as exc:     # noqa: BLE001 - a report names what it could not read, never crashes
            where = traceback.extract_tb(exc.__traceback__)[-1]
            message = f"{type(exc).__name__}: {exc} (in {where.name})"
            problems.append(f"{title}: {message}")
            sections.append(Section(title, [unreadable(f"the {title.lower()} step's files", message)], done=False))
    header = (f"<p class='note'>{esc(date)} · RoboCal {esc(software_version())} · project folder "
              f"{esc(project.folder)} · cell: {esc(project.describe_cell())}</p>")
    by = " · ".join(esc(v.strip()) for v in (author, course) if v and v.strip())
    if by:
        header = f"<p class='author'><b>{by}</b></p>" + header
    report = Report(title=f"RoboCal calibration report: {project.name}", header=header, summary="",
                    sections=sections, footer=FOOTER, problems=problems)
    report.summary = summary_html(report, robot, identification, facts, date)
    return report


def _files_section(project: Project, robot: RobotModel | None) -> Section:
    names = dict(OUTPUT_FILES, marker=MARKER_FILE)
    if project.robot:
        names["robot"] = project.robot
    rows = [[esc(name), "present" if (project.folder / name).is_file() else "<span class='grey'>missing</span>"]
            for name in names.values()]
    return Section("Project files", [table(["file", ""], rows)])


def _verdict(before: float | None, after: float | None) -> str:
    if before is None or after is None or not math.isfinite(before) or not math.isfinite(after):
        return "No held-out validation: the calibration's accuracy on new poses is not known."
    if after <= 0:
        return "Held-out error is zero: check that the validation poses were really left out."
    factor = before / after
    if factor >= 2:
        return f"Calibrated: on poses left out of the fit the robot is {factor:.1f}× more accurate ({after:.3f} mm)."
    if factor > 1.1:
        return (f"Calibrated, with a modest gain ({factor:.2f}×, {after:.3f} mm on held-out poses): more or better "
                "spread poses may help.")
    return ("Not improved: the calibrated model is no more accurate than the nominal one on held-out poses; "
            "check the measurements and the pose spread.")


def summary_html(report: Report, robot: RobotModel | None, identification, facts: dict, date: str) -> str:
    v = facts.get("validation") or {}
    before = (v.get("before") or {}).get("rms_mm")
    after = (v.get("after") or {}).get("rms_mm")
    factor = before / after if before and after else None
    not_done = [s.title for s in report.sections if not s.done]
    if "statistics" not in facts:
        verdict = "Not calibrated yet" + (f": not done or not readable: {', '.join(not_done)}." if not_done else ".")
    else:
        verdict = _verdict(before, after)
    robot_name = robot.name if robot is not None else (
        identification.model.name if identification is not None else "— (the project has no robot model)")
    rows = [("robot", esc(robot_name)),
            ("cameras", esc(facts.get("cameras", "— (no stereo calibration)"))),
            ("date", esc(date)),
            ("software", f"RoboCal {esc(software_version())}"),
            ("stereo reprojection error", num(facts.get("stereo_rms"), 3, "px RMS")),
            ("held-out error, before → after", f"{num(before, 3)} → <b>{num(after, 3)}</b> mm RMS"
             if before is not None else "—"),
            ("improvement factor", f"{factor:.1f}×" if factor else "—")]
    acc = facts.get("accuracy")
    if acc is not None:
        rows.append(("against the true robot (virtual lab)",
                     f"{num(acc.nominal.rms_mm, 3)} → {num(acc.calibrated.rms_mm, 3)} mm RMS"))
    text = (f"<p class='verdict'>{esc(verdict)}</p>"
            + table([], [[esc(k), val] for k, val in rows]))
    if not_done:
        text += f"<p>Not done: {esc(', '.join(not_done))}.</p>"
    if report.problems:
        text += ("<p class='warn'><b>Files that could not be read:</b></p><ul>"
                 + "".join(f"<li class='warn'>{esc(p)}</li>" for p in report.problems) + "</ul>")
    return text
