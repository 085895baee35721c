"""`robocal report PROJECT --out report.pdf [--out report.html]`: the calibration report of a
project folder, with figures, as a self-contained HTML file and/or a PDF (drawn offscreen).
PROJECT may also be a folder the command-line chain wrote into (a `simulate` dataset with the
stereo.yaml, measurements.csv and calibrated.json of the later commands): the nominal robot is
then `--robot` or the dataset's truth.json, the lab's seed the dataset's. `--author`, `--course`
and `--serial` (the robot's serial number) go into the title block (a student's hand-in).

Steps not done are listed as not done; a file that cannot be read is named in the report. The
outputs are written as one: a failure leaves any previous report as it was."""
from __future__ import annotations

import os
from pathlib import Path

from app.commands import CommandResult, check_output
from core.errors import UsageError

HELP = "Write the calibration report of a project (HTML and/or PDF, with figures)"

INPUTS = ("project=PROJECT", "robot")      # checked against OUTPUTS before the run (app/commands/paths.py)
OUTPUTS = ("out",)


def add_arguments(parser) -> None:
    parser.add_argument("project", metavar="PROJECT", help="project folder")
    parser.add_argument("--out", required=True, action="append", metavar="FILE",
                        help="report file to write: .html (self-contained) or .pdf; may be given twice")
    parser.add_argument("--page-size", choices=["a4", "letter"], default="a4", help="PDF page size (default a4)")
    parser.add_argument("--figures", metavar="DIR", help="also write every figure as PNG into DIR")
    parser.add_argument("--author", metavar="NAME", help="who hands the report in (on the title page)")
    parser.add_argument("--course", metavar="TEXT", help="the course or lab it is handed in for (on the title page)")
    parser.add_argument("--serial", metavar="TEXT", help="the robot's serial number (on the title page)")
    parser.add_argument("--robot", metavar="R.json",
                        help="nominal robot of a command-line folder (default: the dataset's truth.json)")
    parser.add_argument("--no-truth", action="store_true",
                        help="virtual lab: skip the comparison with the true robot (it rebuilds the lab, ~3 s)")


def run(args) -> CommandResult:
    if not Path(args.project).is_dir():
        raise UsageError(f"no such project folder: {args.project}")
    for out in args.out:
        if Path(out).suffix.lower() not in (".html", ".htm", ".pdf"):
            raise UsageError(f"--out must end in .html or .pdf, got {out!r}")
        check_output(out, "--out")
    project, robot, seed = _project(args)

    os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")
    from PySide6.QtWidgets import QApplication

    from app.report.render import write_report
    from app.report.truth import project_truth_accuracy

    app = QApplication.instance() or QApplication(["robocal"])   # the figures need one
    try:
        accuracy = None if args.no_truth else project_truth_accuracy(project, robot=robot, lab_seed=seed)
        written = write_report(project, args.out, robot=robot, accuracy=accuracy, page_size=args.page_size,
                               figures_dir=args.figures, author=args.author, course=args.course,
                               serial=args.serial)
    finally:
        app.processEvents()                                       # let the figure widgets go
    reports = [str(p) for p in written if p.suffix.lower() in (".html", ".htm", ".pdf")]
    figures = [str(p) for p in written if str(p) not in reports]
    return CommandResult(text=f"Wrote {', '.join(reports)}" + (f" and {len(figures)} figure files" if figures
                                                                else "") + ".",
                         data={"out": reports, "figures": figures, "project": str(project.folder)})


def _project(args):
    """(project, nominal robot or None, lab seed): a wizard project, or a command-line folder."""
    from core.files import read_json
    from core.project import DATASET_TRUTH, PROJECT_FILE, command_line_folder, open_project
    from core.robot.file import read_robot, robot_from_dict

    robot = read_robot(args.robot) if args.robot else None
    if (Path(args.project) / PROJECT_FILE).is_file():
        return open_project(args.project), robot, 0
    project = command_line_folder(args.project)
    truth = project.folder / DATASET_TRUTH
    if not truth.is_file():
        return project, robot, 0
    data = read_json(truth)
    if robot is None and isinstance(data.get("nominal_robot"), dict):
        robot = robot_from_dict(data["nominal_robot"], source=f"{truth} (nominal_robot)")
    seed = data.get("seed", 0)
    return project, robot, seed if isinstance(seed, int) and not isinstance(seed, bool) and seed >= 0 else 0
