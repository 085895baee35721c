"""The calibration report: what a project folder holds, as sections of tables, numbers and
figure specs (core/report/build.py), rendered to HTML by core/report/document.py; the app
draws the figures (app/report)."""
from core.report.build import build_report
from core.report.document import Figure, Report, Section, render_html

__all__ = ["Figure", "Report", "Section", "build_report", "calibration_report", "render_html"]


def calibration_report(project, **kwargs) -> str:
    """The report as HTML without figure images (each figure named, with why it is missing)."""
    return render_html(build_report(project, **kwargs))
