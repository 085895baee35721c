"""The whole report of a project: header, summary box, one section per step.

    report = build_report(project)                 # what the project folder holds
    report = build_report(project, robot=..., identification=result, accuracy=accuracy)

The in-memory results of a session win over the files (they are what the user has just
seen). The inputs are loaded once (core/report/inputs.py) and each section, like the summary,
is drawn from them alone. A step with no output is listed as not done; a file that cannot be read is named with
its error, never a crash. All lengths in mm, angles in degrees, image errors in px.
"""
from __future__ import annotations

import importlib.metadata
import math
import traceback
from datetime import datetime, timezone

from core.project import Project
from core.report.check import check_section
from core.report.compensation import compensation_section
from core.report.document import Report, Section, esc, num, parameter_name, table, unreadable
from core.report.identification import identification_section, not_separable_pairs
from core.report.inputs import ReportInputs, load_report_inputs
from core.report.marker import marker_section
from core.report.measurement import measurement_section
from core.report.poses import poses_section
from core.report.stereo import cameras_summary, stereo_section
from core.robot.model import RobotModel

CONVENTIONS = ("<p class='note'>Lengths in mm, angles in degrees, image errors in px. RMS = root mean square of the 3D "
          "distance between measured (or true) and predicted marker positions. Held-out poses were left out of "
          "the fit: their error is what the calibrated robot achieves on poses it was not fitted to.</p>")


def software_version() -> str:
    try:
        return importlib.metadata.version("robocal")
    except importlib.metadata.PackageNotFoundError:
        return "unknown"


def build_report(project: Project, *, robot: RobotModel | None = None, identification=None, accuracy=None,
                 date: str | None = None, author: str | None = None, course: str | None = None,
                 serial: str | None = None) -> Report:
    """The report of `project`. `robot`: the nominal model (else the project's robot.json);
    `identification`: an IdentificationResult of this session (else calibrated.json);
    `accuracy`: a model_comparison.TruthAccuracy (virtual lab only); `author`, `course`,
    `serial`: who hands the report in (student or operator), for which course, and the robot's
    serial number, in the title block (left out when not given)."""
    date = date or datetime.now(timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    problems: list[str] = []
    inputs = load_report_inputs(project, robot=robot, identification=identification, accuracy=accuracy,
                                problems=problems)
    robot = inputs.robot
    builders = [("Stereo calibration", stereo_section), ("Marker", marker_section), ("Pose sequence", poses_section),
                ("Measurements", measurement_section), ("Identification", identification_section),
                ("Check", check_section), ("Compensation", compensation_section)]
    sections = []
    for title, build in builders:
        try:
            sections.append(build(inputs, problems))
        except Exception as exc:     # noqa: BLE001 - a report names what it could not read, never crashes
            where = traceback.extract_tb(exc.__traceback__)[-1]
            message = f"{type(exc).__name__}: {exc} (in {where.name})"
            problems.append(f"{title}: {message}")
            sections.append(Section(title, [unreadable(f"the {title.lower()} step's files", message)], done=False))
    robot_name = robot.name if robot is not None else (
        identification.model.name if identification is not None else "the project has no robot model")
    header = title_block(author=author, course=course, robot=robot_name, serial=serial, date=date,
                         cell=project.describe_cell())
    header += (f"<p class='note'>RoboCal {esc(software_version())} · project folder {esc(project.folder)}</p>")
    report = Report(title=f"RoboCal calibration report: {project.name}", header=header, summary="",
                    sections=sections, conventions=CONVENTIONS, problems=problems)
    report.summary = summary_html(report, inputs)
    return report


def title_block(*, author: str | None, course: str | None, robot: str, serial: str | None, date: str,
                cell: str) -> str:
    """The title block under the report's title: who hands it in, the course, the robot and its
    serial number, the date and the cell, two per row; a field not given is left out."""
    fields = [(label, value.strip()) for label, value in
              (("Student / operator", author), ("Course", course), ("Robot", robot), ("Serial number", serial),
               ("Date", date), ("Cell", cell)) if value and value.strip()]
    rows = [fields[i:i + 2] for i in range(0, len(fields), 2)]
    cells = "".join("<tr>" + "".join(f"<td class='label'>{esc(k)}</td><td><b>{esc(v)}</b></td>" for k, v in row)
                    + "</tr>" for row in rows)
    return f"<table class='title' width='100%'>{cells}</table>"


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


def accuracy_table(validation: dict, accuracy) -> str:
    """Mean, RMS and max position error (mm) before and after calibration on the held-out poses
    (and, in the virtual lab, against the true robot)."""
    rows = []
    if validation:
        n = validation.get("n_test_poses")
        where = f"{n} held-out poses" if validation.get("method") == "holdout" else \
            f"{validation.get('folds')}-fold cross validation"
        rows += [(f"{where}, nominal model", validation.get("before") or {}),
                 (f"{where}, calibrated model", validation.get("after") or {})]
    if accuracy is not None:
        a = accuracy.summary()
        k = a.get("n_configurations")
        rows += [(f"true robot at {k} fresh poses (virtual lab), nominal model", a.get("nominal", {})),
                 (f"true robot at {k} fresh poses (virtual lab), calibrated model", a.get("calibrated", {}))]
    return table(["position error (mm)", "mean", "RMS", "max"],
                 [[esc(label), num(st.get("mean_mm")), f"<b>{num(st.get('rms_mm'))}</b>", num(st.get("max_mm"))]
                  for label, st in rows], numeric={1, 2, 3})


def summary_html(report: Report, inputs: ReportInputs) -> str:
    """The summary box: the verdict on the held-out poses, the accuracy table, the cameras and
    what is missing, from the report's inputs (and which sections are done)."""
    calibration = inputs.calibration.get()
    statistics = (calibration.section.get("statistics", {}) or {}) if calibration is not None else None
    validation = statistics.get("validation") if statistics is not None else None
    v = validation if isinstance(validation, dict) else {}
    accuracy = inputs.accuracy if calibration is not None else None
    before = (v.get("before") or {}).get("rms_mm")
    after = (v.get("after") or {}).get("rms_mm")
    not_done = [s.title for s in report.sections if not s.done]
    if statistics is None:
        verdict = "Not calibrated yet" + (f": not done or not readable: {', '.join(not_done)}." if not_done else ".")
    else:
        verdict = _verdict(before, after)
    text = f"<p class='verdict'>{esc(verdict)}</p>"
    if v or accuracy is not None:
        text += accuracy_table(v, accuracy)
    sf = inputs.stereo.get()
    rows = [("cameras", esc(cameras_summary(sf) if sf is not None else "no stereo calibration yet")),
            ("stereo reprojection error", num(sf.rms_stereo if sf is not None else None, 3, "px RMS"))]
    together = not_separable_pairs(calibration.section) if calibration is not None else []
    if together:
        rows.append(("parameters not separable", esc(", ".join(f"{parameter_name(a)}–{parameter_name(b)}"
                                                                  for a, b, _r in together))
                     + " (see Identification)"))
    text += table([], [[esc(k), val] for k, val in rows])
    if not_done:
        text += f"<p>Not done: {esc(', '.join(not_done))}.</p>"
    if report.problems:
        text += ("<p class='warn'><b>Files that could not be read:</b></p><ul>"
                 + "".join(f"<li class='warn'>{esc(p)}</li>" for p in report.problems) + "</ul>")
    return text
