"""The calibration report as files: a self-contained HTML (figures as base64 PNG) and a PDF
printed with QTextDocument + QPdfWriter (A4 or Letter; each section on a new page; figures
never split, being single images; "page N of M" at the foot of every page).

    written = write_report(project, ["report.html", "report.pdf"])

Both files are written as one (core.files.atomic_write_many): a failure leaves every
previous report as it was. Needs a QApplication (offscreen is enough)."""
from __future__ import annotations

import base64
from pathlib import Path

from PySide6.QtCore import QBuffer, QByteArray, QIODevice, QMarginsF, QRectF, QSizeF, Qt, QUrl
from PySide6.QtGui import QFont, QPageLayout, QPageSize, QPainter, QPdfWriter, QTextDocument

from app.report.figures import png_bytes, render_png
from core.errors import UsageError
from core.files import atomic_write_many, ensure_writable_dir
from core.report import Report, build_report, render_html
from core.task import Monitor

PAGE_SIZES = {"a4": QPageSize.PageSizeId.A4, "letter": QPageSize.PageSizeId.Letter}
SUFFIXES = (".html", ".htm", ".pdf")
PDF_DPI = 300
MARGIN_MM = 15.0
FOOTER_MM = 8.0
FIGURE_FULL_WIDTH = 900       # figure px that fill the text width
SCREEN_DPI = 96               # QTextDocument sizes images in 96 dpi pixels, scaled to the paint device


def draw_figures(report: Report, *, draw=None, progress=None, cancelled=None) -> dict:
    """Figure key -> QImage of every figure that has something to draw. `draw(figure,
    cancelled)`: how to draw one (default: here, on the GUI thread; a worker passes
    `GuiDrawer.draw`)."""
    monitor = Monitor(progress, cancelled)
    todo = [f for f in report.figures() if not f.unavailable and f.panels]
    images = {}
    for i, fig in enumerate(todo):
        monitor.step(i / max(len(todo), 1), f"drawing figure {i + 1} of {len(todo)}: {fig.title}")
        images[fig.key] = draw(fig, cancelled) if draw is not None else render_png(fig)
    monitor.step(1.0, "figures drawn")
    return images


def html_document(report: Report, images: dict) -> str:
    """Self-contained HTML: each image a data URI."""
    srcs = {k: "data:image/png;base64," + base64.b64encode(png_bytes(img)).decode("ascii")
            for k, img in images.items()}
    return render_html(report, srcs, scale=0.85)


def pdf_document(report: Report, images: dict, page_size: str = "a4") -> bytes:
    """The report printed to PDF, as bytes."""
    data = QByteArray()
    buffer = QBuffer(data)
    buffer.open(QIODevice.OpenModeFlag.WriteOnly)
    writer = QPdfWriter(buffer)
    writer.setResolution(PDF_DPI)
    writer.setTitle(report.title)
    writer.setCreator("RoboCal")
    writer.setPageLayout(QPageLayout(QPageSize(PAGE_SIZES[page_size]), QPageLayout.Orientation.Portrait,
                                     QMarginsF(MARGIN_MM, MARGIN_MM, MARGIN_MM, MARGIN_MM),
                                     QPageLayout.Unit.Millimeter))
    rect = writer.pageLayout().paintRectPixels(PDF_DPI)
    footer = FOOTER_MM / 25.4 * PDF_DPI
    page_h = rect.height() - footer

    doc = QTextDocument()
    doc.documentLayout().setPaintDevice(writer)      # pt sizes in the writer's pixels
    doc.setDocumentMargin(0)
    font = QFont("DejaVu Sans")
    font.setPointSizeF(9.5)
    doc.setDefaultFont(font)
    doc.setPageSize(QSizeF(rect.width(), page_h))
    for key, img in images.items():
        doc.addResource(QTextDocument.ResourceType.ImageResource, QUrl(f"figure:{key}"), img)
    doc.setHtml(render_html(report, {k: f"figure:{k}" for k in images}, page_breaks=True,
                            scale=rect.width() * SCREEN_DPI / PDF_DPI / FIGURE_FULL_WIDTH * 0.97))
    pages = doc.pageCount()
    painter = QPainter(writer)
    try:
        note = QFont(font)
        note.setPointSizeF(8)
        for i in range(pages):
            if i:
                writer.newPage()
            painter.save()
            painter.translate(0, -i * page_h)
            doc.drawContents(painter, QRectF(0, i * page_h, rect.width(), page_h))
            painter.restore()
            painter.setFont(note)
            painter.setPen(Qt.GlobalColor.darkGray)
            foot = QRectF(0, page_h, rect.width(), footer)
            painter.drawText(foot, Qt.AlignmentFlag.AlignBottom | Qt.AlignmentFlag.AlignLeft, report.title)
            painter.drawText(foot, Qt.AlignmentFlag.AlignBottom | Qt.AlignmentFlag.AlignRight,
                             f"page {i + 1} of {pages}")
    finally:
        painter.end()
        buffer.close()
    return bytes(data)


def check_report_path(path: str | Path, option: str = "--out") -> Path:
    path = Path(path)
    if path.suffix.lower() not in SUFFIXES:
        raise UsageError(f"{option} must end in .html or .pdf, got {str(path)!r}")
    return path


def write_report(project, outputs, *, robot=None, identification=None, accuracy=None, page_size: str = "a4",
                 figures_dir: str | Path | None = None, draw=None, progress=None, cancelled=None,
                 author: str | None = None, course: str | None = None) -> list[Path]:
    """Build the report of `project` and write it to each path of `outputs` (.html or .pdf) as one
    atomic write; with `figures_dir`, also every figure as PNG there. Runs on a worker when
    `draw` is a `GuiDrawer.draw` (app/report/gui_drawer.py); without it, on the GUI thread.
    Output folders are checked before any work: one that cannot be written to is named at once."""
    monitor = Monitor(progress, cancelled)
    outputs = [check_report_path(p) for p in outputs]
    for folder in {p.parent for p in outputs} | ({Path(figures_dir)} if figures_dir is not None else set()):
        ensure_writable_dir(folder)
    monitor.step(0.0, "reading the project")
    report = build_report(project, robot=robot, identification=identification, accuracy=accuracy, author=author,
                          course=course)
    images = draw_figures(report, draw=draw, progress=monitor.sub(0.05, 0.7), cancelled=cancelled)
    files: dict = {}
    for i, path in enumerate(outputs):
        monitor.step(0.7 + 0.25 * i / len(outputs), f"writing {path.name}")
        files[path] = (pdf_document(report, images, page_size) if path.suffix.lower() == ".pdf"
                       else html_document(report, images))
    if figures_dir is not None:
        folder = Path(figures_dir)
        for fig in report.figures():
            if fig.key in images:
                files[folder / f"{fig.key}.png"] = png_bytes(images[fig.key])
    monitor.step(0.95, "saving")
    written = atomic_write_many(files)
    monitor.step(1.0, "report written")
    return written
