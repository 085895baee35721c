"""`robocal report PROJECT --out report.pdf [--out report.html]`: the calibration report of a
project folder, with figures, as a self-contained HTML file and/or a PDF (drawn offscreen).

Steps not done are listed as not done; a file that cannot be read is named in the report. The
outputs are written as one: a failure leaves any previous report as it was."""
from __future__ import annotations

import os
from pathlib import Path

from app.commands import CommandResult, check_output
from core.errors import UsageError

HELP = "Write the calibration report of a project (HTML and/or PDF, with figures)"

INPUTS = ("project=PROJECT",)      # checked against OUTPUTS before the run (app/commands/paths.py)
OUTPUTS = ("out",)


def add_arguments(parser) -> None:
    parser.add_argument("project", metavar="PROJECT", help="project folder")
    parser.add_argument("--out", required=True, action="append", metavar="FILE",
                        help="report file to write: .html (self-contained) or .pdf; may be given twice")
    parser.add_argument("--page-size", choices=["a4", "letter"], default="a4", help="PDF page size (default a4)")
    parser.add_argument("--figures", metavar="DIR", help="also write every figure as PNG into DIR")
    parser.add_argument("--no-truth", action="store_true",
                        help="virtual lab: skip the comparison with the true robot (it rebuilds the lab, ~3 s)")


def run(args) -> CommandResult:
    from core.project import open_project

    if not Path(args.project).is_dir():
        raise UsageError(f"no such project folder: {args.project}")
    for out in args.out:
        if Path(out).suffix.lower() not in (".html", ".htm", ".pdf"):
            raise UsageError(f"--out must end in .html or .pdf, got {out!r}")
        check_output(out, "--out")
    project = open_project(args.project)

    os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")
    from PySide6.QtWidgets import QApplication

    from app.report.render import write_report
    from app.report.truth import project_truth_accuracy

    app = QApplication.instance() or QApplication(["robocal"])   # the figures need one
    try:
        accuracy = None if args.no_truth else project_truth_accuracy(project)
        written = write_report(project, args.out, accuracy=accuracy, page_size=args.page_size,
                               figures_dir=args.figures)
    finally:
        app.processEvents()                                       # let the figure widgets go
    reports = [str(p) for p in written if p.suffix.lower() in (".html", ".htm", ".pdf")]
    figures = [str(p) for p in written if str(p) not in reports]
    return CommandResult(text=f"Wrote {', '.join(reports)}" + (f" and {len(figures)} figure files" if figures
                                                                else "") + ".",
                         data={"out": reports, "figures": figures, "project": str(project.folder)})
